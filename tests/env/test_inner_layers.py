"""Vias to inner layers, on a real four-layer board (D3-A test board `radio_saw_dcc6c`, the
smallest board with inner layers in the shipped release manifests), built alone from the
PCBench snapshot."""
from __future__ import annotations

import numpy as np
import pytest

from pcbdata.env.types import (
    MAKE_LINE,
    MAKE_VIA,
    NET_END,
    NET_SELECT,
    RING,
    START_ROUTE,
    WALKAROUND,
)
from tests.conftest import build_from_snapshot

FOUR_LAYERS = "radio_saw_dcc6c"


@pytest.fixture(scope="module")
def four_layer_set(tmp_path_factory, kicad_pool):
    root, summary = build_from_snapshot(tmp_path_factory.mktemp("four"), [FOUR_LAYERS],
                                        kicad_pool, "the four-layer board")
    assert summary["tiers"]["d3-a"]["test"] == 1
    return root


def _act(env, kind, **given):
    return env.step({"type": kind, "net": 0, "candidate": 0, "mode": WALKAROUND, **given})


def test_a_via_reaches_an_inner_layer(four_layer_set):
    import pcbdata.env

    env = pcbdata.env.make(four_layer_set, "d3-a", drc="terminal")
    try:
        obs, info = env.reset(options={"index": 0})
        layers = info["layers"]
        assert len(layers) == 4  # (its own names: 1_top, 2_gnd, 3_gnd, 4_bot)
        # Start on an SMD or top-side pad, then walk a via down to each layer in turn.
        net = int(np.flatnonzero(info["action_mask"]["net"])[0])
        vias_before, copper = info["vias"], len(env.unwrapped._snap["copper"])
        _act(env, NET_SELECT, net=net)
        masks = env.unwrapped.action_masks()
        start = int(np.flatnonzero(masks["candidate"])[0])
        obs, _, _, _, info = _act(env, START_ROUTE, candidate=start)
        head = obs["router_head"]
        at, layer = tuple(head["position"]), int(head["layer"])
        cands = head["candidates"]
        here = {int(c[3]): i for i, c in enumerate(cands)
                if int(c[0]) == RING and tuple(c[1:3]) == at}
        assert sorted(here) == sorted(set(range(4)) - {layer})  # the head's point per layer
        inner = 1
        mask = env.unwrapped.action_masks()
        assert mask["candidate_via"][here[inner]] and not mask["candidate"][here[inner]]
        obs, _, _, _, info = _act(env, MAKE_VIA, candidate=here[inner])
        assert info["router"]["ok"], info["router"]
        assert int(obs["router_head"]["layer"]) == inner and info["vias"] == vias_before + 1
        # A line on the inner layer: the walkaround router routes there, KiCad holds it.
        mask = env.unwrapped.action_masks()
        ring = [i for i in range(8) if mask["candidate"][i]]
        assert ring, "no ring point on the inner layer is inside the board"
        obs, _, _, _, info = _act(env, MAKE_LINE, candidate=ring[0])
        assert info["router"]["ok"], info["router"]
        on_inner = [r for r in env.unwrapped._snap["copper"]
                    if r["kind"] != "via" and r["layer"] == layers[inner]]
        assert len(on_inner) == 1
        # Nothing joins that route to a second pad: net_end takes it up again.
        obs, _, _, _, info = _act(env, NET_END)
        assert info["vias"] == vias_before and len(env.unwrapped._snap["copper"]) == copper
    finally:
        env.close()

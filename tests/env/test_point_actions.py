"""The free-coordinate action form (pcbdata's extension, the paper's action surface): `x`, `y`
in mm (+ `layer`) instead of a candidate index, on real D2 boards judged by KiCad."""
from __future__ import annotations

import numpy as np
import pytest

from pcbdata.env.masks import POINT_TOLERANCE_NM
from pcbdata.env.types import (
    MAKE_LINE,
    MAKE_VIA,
    MARK_OBSTACLES,
    NET_END,
    NET_SELECT,
    START_ROUTE,
    WALKAROUND,
)


def _two_pad_net(env):
    """(net index, pad a, pad b) of the first net with two pads on a shared layer."""
    static = env.unwrapped.static
    for i, net in enumerate(static.nets):
        pads = [static.pads[k] for k in static.pads_of(net.name)]
        if len(pads) == 2 and set(pads[0].layers) & set(pads[1].layers):
            return i, pads[0], pads[1]
    raise AssertionError("no two-pad net on a shared layer")


def mm(nm: int) -> float:
    return nm / 1e6


@pytest.fixture
def env(make_env):
    e = make_env("d2", drc="step")
    e.reset(seed=0, options={"board_id": "board_00000"})
    return e


def test_start_route_at_a_pad_centre_within_the_tolerance(env):
    net, a, _ = _two_pad_net(env)
    layer = sorted(set(a.layers))[0]
    env.step({"type": NET_SELECT, "net": net})
    off = (POINT_TOLERANCE_NM - 1) / 1e6
    _, _, _, _, info = env.step({"type": START_ROUTE, "x": mm(a.x) + off, "y": mm(a.y),
                                 "layer": layer})
    assert info["rejected"] is None and info["phase"] == "routing"
    head = env.unwrapped._head
    assert (head.x, head.y, head.layer) == (a.x, a.y, layer)  # snapped to the pad centre


@pytest.mark.parametrize("change, reason", [
    ({"dx": 2 * POINT_TOLERANCE_NM / 1e6}, "is no pad centre, track end or via of net"),
    ({"layer": None}, "start_route by coordinates needs a layer"),
])
def test_start_route_elsewhere_is_masked_with_the_reason(env, change, reason):
    net, a, _ = _two_pad_net(env)
    env.step({"type": NET_SELECT, "net": net})
    action = {"type": START_ROUTE, "x": mm(a.x) + change.get("dx", 0.0), "y": mm(a.y),
              "layer": change.get("layer", sorted(a.layers)[0])}
    _, reward, _, _, info = env.step(action)
    assert reason in info["rejected"] and reward == 0.0 and info["phase"] == "net"


def test_make_line_to_any_point_lays_exactly_that_copper(env):
    net, a, b = _two_pad_net(env)
    layer = sorted(set(a.layers) & set(b.layers))[0]
    env.step({"type": NET_SELECT, "net": net})
    env.step({"type": START_ROUTE, "x": mm(a.x), "y": mm(a.y), "layer": layer})
    corner = (a.x, b.y)  # an L through a point no candidate offers
    _, _, _, _, info = env.step({"type": MAKE_LINE, "x": mm(corner[0]), "y": mm(corner[1]),
                                 "mode": MARK_OBSTACLES})
    assert info["rejected"] is None and info["router"]["ok"]
    _, _, terminated, _, info = env.step({"type": MAKE_LINE, "x": mm(b.x), "y": mm(b.y),
                                          "mode": MARK_OBSTACLES})
    geo = env.unwrapped.board_view().geometry
    ends = sorted((i.start, i.end) for i in geo.copper if i.kind == "track")
    assert ends == sorted([((a.x, a.y), corner), (corner, (b.x, b.y))])
    assert info["rejected"] is None
    view = env.unwrapped.board_view()
    pads = env.unwrapped.static.pads
    ia = next(i for i, p in enumerate(pads) if (p.x, p.y) == (a.x, a.y))
    ib = next(i for i, p in enumerate(pads) if (p.x, p.y) == (b.x, b.y))
    assert view.pad_cluster[ia] == view.pad_cluster[ib]  # KiCad joins them


def test_walkaround_and_via_to_points(env):
    net, a, b = _two_pad_net(env)
    layer = sorted(set(a.layers) & set(b.layers))[0]
    env.step({"type": NET_SELECT, "net": net})
    env.step({"type": START_ROUTE, "x": mm(a.x), "y": mm(a.y), "layer": layer})
    mid = ((a.x + b.x) // 2, (a.y + b.y) // 2)
    _, _, _, _, info = env.step({"type": MAKE_VIA, "x": mm(mid[0]), "y": mm(mid[1]),
                                 "mode": WALKAROUND})
    assert info["rejected"] is None
    if info["router"]["ok"]:
        assert env.unwrapped._head.layer != layer and info["vias"] == 1


@pytest.mark.parametrize("action, reason", [
    ({"type": MAKE_LINE, "x": 1e4, "y": 1e4, "mode": 0}, "outside the board outline"),
    ({"type": MAKE_LINE, "x": 1.0}, "malformed action: x without y"),
    ({"type": MAKE_LINE, "x": float("nan"), "y": 1.0}, "not a finite coordinate"),
    ({"type": NET_END, "x": 1.0, "y": 1.0}, "takes no x, y"),
])
def test_bad_points_are_no_ops_with_the_reason(env, action, reason):
    net, a, _ = _two_pad_net(env)
    env.step({"type": NET_SELECT, "net": net})
    env.step({"type": START_ROUTE, "x": mm(a.x), "y": mm(a.y), "layer": sorted(a.layers)[0]})
    _, reward, _, _, info = env.step(action)
    assert reason in info["rejected"] and reward == 0.0


def test_same_point_actions_give_the_same_episode(make_env):
    def episode():
        e = make_env("d2", drc="step")
        obs, _ = e.reset(seed=0, options={"board_id": "board_00001"})
        net, a, b = _two_pad_net(e)
        layer = sorted(set(a.layers) & set(b.layers))[0]
        rewards = []
        for act in ({"type": NET_SELECT, "net": net},
                    {"type": START_ROUTE, "x": mm(a.x), "y": mm(a.y), "layer": layer},
                    {"type": MAKE_LINE, "x": mm(b.x), "y": mm(b.y), "mode": WALKAROUND}):
            obs, r, *_ = e.step(act)
            rewards.append(r)
        return obs["routing_geometry"]["tracks"].copy(), rewards

    (t1, r1), (t2, r2) = episode(), episode()
    assert np.array_equal(t1, t2) and r1 == r2

"""Observations as the network reads them: only the rows that hold an entity, padded per batch.

The RL wrapper's table has a row for every capacity slot (1730 on D2, most of them padding); the
network reads the net and candidate blocks whole (the pointer heads index them by position),
then the head row (at position `n_nets + n_cands`, read by the heads beside the pooled summary)
and only the valid rows of the other families, so a 20-pad board costs about 100 rows, not
1730. Each row carries the derived columns of `pcbdata.learn.derived`. Pure numpy: `compact`
runs in the environment loop, `collate` pads a batch.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pcbdata.env.wrappers import features
from pcbdata.env.wrappers.rl import joint_masks
from pcbdata.learn import derived

#: Input width per row: the asinh of the 14 columns, the family one-hot, "of the head's net",
#: the derived columns.
N_FAMILIES = len(features.FAMILIES)
WIDTH = len(features.COLUMNS) + N_FAMILIES + 1 + derived.WIDTH


def _rows(obs: Mapping[str, np.ndarray], extra: np.ndarray) -> np.ndarray:
    """Per-row inputs; the step counters are zeroed: they depend on max_steps, which a rollout
    may set differently from training."""
    table = np.asarray(obs["entities"], dtype=np.float32).copy()
    types = np.asarray(obs["entity_type"], dtype=np.int64)
    nets = np.asarray(obs["entity_net"], dtype=np.int64)
    table[types == features.BOARD, features.B] = 0.0
    table[types == features.HEAD, features.COUNT] = 0.0
    head_net = nets[types == features.HEAD, 0]
    mine = (nets[:, 0] >= 0) & (nets[:, 0] == (head_net[0] if len(head_net) else -1))
    onehot = np.eye(N_FAMILIES, dtype=np.float32)[types]
    return np.concatenate((np.arcsinh(table), onehot, mine[:, None].astype(np.float32), extra),
                          axis=1)


def compact(obs: Mapping[str, np.ndarray], extra: np.ndarray | None = None) -> dict[str, Any]:
    """One observation (the RL wrapper's dict) and its derived columns (`EpisodeReader.read`;
    None: zeros, as for an agent with no memory): net rows, candidate rows, the head row, then
    the other families' valid rows; `valid` marks rows holding an entity."""
    types = np.asarray(obs["entity_type"])
    valid = np.asarray(obs["entity_mask"]).astype(bool)
    if extra is None:
        extra = np.zeros((len(types), derived.WIDTH), dtype=np.float32)
    first = (types == features.NET) | (types == features.CANDIDATE) | (types == features.HEAD)
    order = np.concatenate((np.flatnonzero(types == features.NET),
                            np.flatnonzero(types == features.CANDIDATE),
                            np.flatnonzero(types == features.HEAD),
                            np.flatnonzero(~first & valid)))
    return {"x": _rows(obs, extra)[order], "valid": valid[order],
            "n_nets": np.int64((types == features.NET).sum()),
            "n_cands": np.int64((types == features.CANDIDATE).sum()),
            "index_mask": np.asarray(obs["index_mask"]).astype(bool),
            "mode_mask": np.asarray(obs["mode_mask"]).astype(bool)}


def collate(items: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Pads a batch of `compact` observations to its longest; all of one layout (nets, K)."""
    longest = max(len(it["x"]) for it in items)
    x = np.zeros((len(items), longest, WIDTH), dtype=np.float32)
    valid = np.zeros((len(items), longest), dtype=bool)
    for i, it in enumerate(items):
        x[i, : len(it["x"])] = it["x"]
        valid[i, : len(it["valid"])] = it["valid"]
    return {"x": x, "valid": valid, "n_nets": int(items[0]["n_nets"]),
            "n_cands": int(items[0]["n_cands"]),
            "index_mask": np.stack([it["index_mask"] for it in items]),
            "mode_mask": np.stack([it["mode_mask"] for it in items])}


def wrapped_observation(raw: dict, masks: dict, layout: features.Layout,
                        static: features.StaticRows | None) -> dict[str, np.ndarray]:
    """The RL wrapper's observation (the keys `compact` reads) of a raw one, for agents that
    see the environment's own observation (`pcbdata rollout`)."""
    k = max(layout.blocks[features.NET][1], layout.blocks[features.CANDIDATE][1])
    index, mode = joint_masks(masks, k)
    table, nets, valid, _ = features.entity_table(raw, masks, layout, 1, static)
    return {"entities": table, "entity_type": layout.types(), "entity_net": nets,
            "entity_mask": valid, "index_mask": index, "mode_mask": mode}


def layout_of(raw: dict) -> features.Layout:
    """The row blocks of a raw observation, read from its arrays' capacities."""
    s, g, h = raw["board_static"], raw["routing_geometry"], raw["router_head"]

    class _Caps:
        max_outline_points, max_nets, max_pads = len(s["outline"]), len(s["nets"]), len(s["pads"])
        max_tracks, max_vias, max_ratsnest = len(g["tracks"]), len(g["vias"]), len(g["ratsnest"])
        max_candidates, max_violations = len(h["candidates"]), len(raw["drc"]["violations"])

    return features.Layout.from_options(_Caps)

"""The searches' corner nodes under one set of rules, worked out from an earlier board state.

Every walkaround and layered search starts from its rules' corner nodes: the corners of the
octagonal keep-out around each obstacle (and the inset board corners) that lie inside the
board and clear of every obstacle (`WalkaroundRouter._corner_nodes`, `_Rules.failing`).
Worked out afresh, that is one clearance test per corner of every obstacle on the layer,
and the negotiated planner asks for it after each connection it lays: on a large board the
same few thousand corners, judged again for every connection.

A corner's verdict depends only on the obstacles within its reach, so a later state's corners
follow from an earlier state's under the same layer, outline, width and clearance (the
earlier request's net may differ: only the obstacles count) where the two differ by a few
obstacles (`added`, `removed`):

- the corners of removed obstacles go, and those of added obstacles come, judged on the
  whole layer;
- a corner that was clear stays clear unless an added obstacle is too close (judged
  against the added obstacles alone);
- a corner that was blocked stays blocked unless it lies within reach of a removed obstacle
  (its blocker may have gone): those are judged on the whole layer again.

A clearance verdict is "too close to one obstacle or more", one (corner, obstacle) pair at a
time, so these are the same verdicts as a fresh pass, and `clear_corners` gives the same
array (`tests/router/test_corners.py` checks it against a fresh pass along a negotiated plan).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from pcbdata.router.clearance import _Layer, _Rules
from pcbdata.router.geometry import CopperItem, item_sort_key

#: A later state is worked out from an earlier one where they differ by at most this many
#: obstacles, or this share of the later one's (else afresh).
DERIVE_MIN, DERIVE_SHARE = 32, 0.125
#: Earlier states kept per layer, outline, width and clearance.
KEPT = 4


@dataclass(frozen=True)
class CornerSet:
    """One state's candidate corners under one set of rules: `points` (k, 2), inside the
    board; `owner`, the layer record each came from (-1: a board corner); `clear`, the
    verdict; `obstacles`, the `id`s of the items that were obstacles; `items`, the layer's
    items in record order; `reach`, per item the box within which a corner can be too close
    to it."""

    obstacles: frozenset
    items: tuple[CopperItem, ...]
    reach: np.ndarray
    points: np.ndarray
    owner: np.ndarray
    clear: np.ndarray

    def corners(self) -> np.ndarray:
        return unique_points(self.points[self.clear])


def unique_points(points: np.ndarray) -> np.ndarray:
    """`np.unique(points, axis=0)` as int64 for whole-nanometre points (n, 2): the rows
    sorted by x then y, each once. Each row becomes one order-keeping integer code, so the
    sort is one of plain integers (far cheaper than sorting rows); the same rows come out."""
    p = np.asarray(points).astype(np.int64).reshape(-1, 2)
    if not len(p):
        return p
    lo, hi = p.min(axis=0), p.max(axis=0)
    span = int(hi[1] - lo[1]) + 1
    if (int(hi[0] - lo[0]) + 1) * span >= 2 ** 62:  # codes would overflow: rows, slowly
        return np.unique(p, axis=0)
    codes = np.unique((p[:, 0] - lo[0]) * span + (p[:, 1] - lo[1]))
    return np.stack([codes // span + lo[0], codes % span + lo[1]], axis=1)


def corner_nodes(router, rules: _Rules) -> np.ndarray:
    """The rules' corner nodes inside the board and clear of its copper, sorted (int64),
    worked out once per rules (every search under them, on one layer or several, starts from
    these): for a router's rules from a kept earlier state where one is close enough
    (`clear_corners`), else afresh."""
    if rules.corners is None:
        rules.corners = (clear_corners(router, rules) if rules.state is not None
                         else _fresh(router, rules, (), frozenset()).corners())
    return rules.corners


def clear_corners(router, rules: _Rules) -> np.ndarray:
    """`corner_nodes` of a router's rules (`WalkaroundRouter._rules`: they know their state
    and net), from the closest kept earlier state if it is close enough, else afresh; the
    result is kept for later states."""
    state, net = rules.state, rules.net
    items = state.value[2]
    # obstacles by identity (a kept set holds its items, so no identity is reused meanwhile;
    # an equal item made anew counts as one removed and one added: the same corners)
    obstacles = frozenset(id(it) for it in items if it.net != net or it.net == "")
    group = (rules.layer_name, state.value[0], state.value[1], rules.half_width,
             rules.clearance)
    kept = router._shared.corner_sets.get(group, [])
    sizes = [len(obstacles ^ old.obstacles) for old in kept]
    limit = max(DERIVE_MIN, int(DERIVE_SHARE * len(obstacles)))
    if sizes and min(sizes) <= limit:
        old = kept[sizes.index(min(sizes))]
        found = _derived(router, rules, items, obstacles, old, obstacles - old.obstacles,
                         old.obstacles - obstacles)
    else:
        found = _fresh(router, rules, items, obstacles)
    router._shared.remember_corners(group, found, KEPT)
    return found.corners()


def _fresh(router, rules: _Rules, items, obstacles: frozenset) -> CornerSet:
    points, owner = router._corner_candidates(rules, None)
    inside = router._inside(points)
    points, owner = points[inside], owner[inside]
    clear = ~rules.failing(_dots(points)) if len(points) else np.zeros(0, dtype=bool)
    return CornerSet(obstacles, items, _reach(rules, len(items)), points, owner, clear)


def _derived(router, rules: _Rules, items, obstacles: frozenset, old: CornerSet,
             added: frozenset, removed: frozenset) -> CornerSet:
    index = {id(item): i for i, item in enumerate(items)}
    # The earlier state's candidates of obstacles still there, renumbered to this layer.
    renumber = np.array([-1 if id(it) in removed else index.get(id(it), -1)
                         for it in old.items] + [-1], dtype=np.int64)
    keep = (old.owner < 0) | (renumber[old.owner] >= 0)
    points, owner = old.points[keep], renumber[old.owner[keep]]
    clear = old.clear[keep].copy()
    if added:  # a clear corner stays clear unless an added obstacle is too close
        check = np.flatnonzero(clear)
        if len(check):
            chosen = [it for it in items if id(it) in added]
            clear[check] = ~_rules_of(router, rules, chosen).failing(_dots(points[check]))
    if removed:  # a blocked corner within reach of a removed obstacle: judged again
        gone = np.array([i for i, it in enumerate(old.items) if id(it) in removed],
                        dtype=np.int64)
        near = np.zeros(len(points), dtype=bool)
        for x0, y0, x1, y1 in old.reach[gone]:
            near |= ((points[:, 0] >= x0) & (points[:, 0] <= x1)
                     & (points[:, 1] >= y0) & (points[:, 1] <= y1))
        redo = np.flatnonzero(~clear & near)
        if len(redo):
            clear[redo] = ~rules.failing(_dots(points[redo]))
    if added:  # the added obstacles' own corners, judged on the whole layer
        more, more_owner = router._corner_candidates(
            rules, np.array(sorted(index[i] for i in added), dtype=np.int64))
        inside = router._inside(more)
        more, more_owner = more[inside], more_owner[inside]
        if len(more):
            points = np.concatenate([points, more])
            owner = np.concatenate([owner, more_owner])
            clear = np.concatenate([clear, ~rules.failing(_dots(more))])
    return CornerSet(obstacles, items, _reach(rules, len(items)), points, owner, clear)


def _reach(rules: _Rules, n: int) -> np.ndarray:
    """(n, 4): per item of the layer, its core's box grown by its allowed distance and a
    nanometre (a corner outside cannot be too close to it); empty boxes for items that are no
    obstacle."""
    box = np.asarray(shapely.bounds(rules.layer.cores[:n]), dtype=float).reshape(-1, 4)
    grow = rules.need[:n] + 1.0  # -inf for the request's own net: an empty box
    return np.column_stack([box[:, :2] - grow[:, None], box[:, 2:] + grow[:, None]])


def _rules_of(router, rules: _Rules, chosen: list[CopperItem]) -> _Rules:
    """The rules for these obstacles alone (same width, clearance and edge clearance)."""
    records = [(item.kind, item.net, item.clearance, router._cache[item])
               for item in sorted(chosen, key=item_sort_key)]
    return _Rules(_Layer(records), -2, rules.half_width, rules.clearance,
                  router.board.edge_clearance)


def _dots(points: np.ndarray) -> np.ndarray:
    return np.stack([points, points], axis=1)

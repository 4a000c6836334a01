"""The phase machine and per-argument masks (SPEC section 6).

Phases: no net -> `net_select`; a net, no head -> `start_route`, `net_select`, `net_end`;
routing -> `make_line`, `make_via`, `finish`, `net_end`. `idle` is always allowed. Masks:
`type` (7), `net` (nets with at least two pads), `candidate` (for `start_route` in phase
`net`, for `make_line` in phase `routing`), `candidate_via` (for `make_via`: a candidate on
the head's layer gives a via to the other outer layer; on boards with inner layers, a candidate
on another layer gives a via to that layer), `mode`.
"""
from __future__ import annotations

import numpy as np

from pcbdata.env.types import (
    EMPTY,
    FINISH,
    IDLE,
    MAKE_LINE,
    MAKE_VIA,
    MODES,
    NET,
    NET_END,
    NET_SELECT,
    NO_NET,
    PAD,
    RING,
    ROUTING,
    START_ROUTE,
    TRACK_END,
    VIA,
    Candidate,
    Head,
    StaticBoard,
)

#: How far a free-coordinate `start_route` point may lie from the pad centre, track end or via
#: it names (nm): 0.001 mm, the paper's three decimals.
POINT_TOLERANCE_NM = 1000

#: Modes an environment cannot offer, with the reason (none today; kept for modes to come).
MODE_UNAVAILABLE: dict[int, str] = {}


def phase_of(net: str | None, head: Head | None) -> int:
    return NO_NET if net is None else (NET if head is None else ROUTING)


def mode_mask() -> tuple[np.ndarray, dict[str, str]]:
    mask = np.ones(len(MODES), dtype=np.int8)
    reasons = {MODES[m]: r for m, r in MODE_UNAVAILABLE.items()}
    for name in reasons:
        mask[MODES.index(name)] = 0
    return mask, reasons


def net_mask(static: StaticBoard, size: int) -> np.ndarray:
    mask = np.zeros(size, dtype=np.int8)
    for i, net in enumerate(static.nets[:size]):
        mask[i] = len(static.pads_of(net.name)) >= 2
    return mask


def inside(static: StaticBoard, x: int, y: int, margin: int) -> bool:
    """(x, y) inside the outer outline ring, at least `margin` from its edges."""
    ring = static.outline[0]
    inside = False
    for (x1, y1), (x2, y2) in zip(ring, ring[1:] + ring[:1]):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
        if _segment_distance(x, y, x1, y1, x2, y2) < margin:
            return False
    return inside


def _segment_distance(px, py, x1, y1, x2, y2) -> float:
    dx, dy = x2 - x1, y2 - y1
    length = dx * dx + dy * dy
    t = 0.0 if length == 0 else max(0.0, min(1.0, ((px - x1) * dx + (py - y1) * dy) / length))
    return ((px - x1 - t * dx) ** 2 + (py - y1 - t * dy) ** 2) ** 0.5


def candidate_masks(static: StaticBoard, cands: list[Candidate], head: Head | None,
                    margin: int) -> tuple[np.ndarray, np.ndarray]:
    """(start_route or make_line mask, make_via mask) over the candidate slots."""
    line = np.zeros(len(cands), dtype=np.int8)
    via = np.zeros(len(cands), dtype=np.int8)
    one_layer = static.grid_pitch is not None  # D1: F.Cu only, no vias
    for i, c in enumerate(cands):
        if c.kind == EMPTY or (one_layer and c.layer != 0):
            continue
        if head is None:
            line[i] = c.kind in (PAD, VIA, TRACK_END)
            continue
        if c.kind == RING and not inside(static, c.x, c.y, margin):
            continue
        if c.layer == head.layer:
            line[i] = (c.x, c.y) != (head.x, head.y)
            via[i] = not one_layer
        else:  # a via to the layer the candidate names (boards with inner layers)
            via[i] = len(static.layers) > 2
    return line, via


def type_mask(phase: int, any_net: bool, line: np.ndarray, via: np.ndarray,
              can_finish: bool) -> np.ndarray:
    mask = np.zeros(7, dtype=np.int8)
    mask[IDLE] = 1
    mask[NET_SELECT] = any_net and phase in (NO_NET, NET)
    mask[NET_END] = phase in (NET, ROUTING)
    mask[START_ROUTE] = phase == NET and bool(line.any())
    mask[MAKE_LINE] = phase == ROUTING and bool(line.any())
    mask[MAKE_VIA] = phase == ROUTING and bool(via.any())
    mask[FINISH] = phase == ROUTING and can_finish
    return mask

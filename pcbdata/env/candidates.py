"""Candidate points of a step (SPEC section 6), in a deterministic order:

- slots 0-7: the ring around the head, direction k at k * 45 degrees in board coordinates
  (x right, y down): E, SE, S, SW, W, NW, N, NE; radius `ring_mm`, diagonals with equal |dx|
  and |dy| so that every ring segment is octilinear. D1: only E, S, W, N, one lattice pitch
  away and snapped to the lattice. Empty (kind `empty`) without a head;
- on boards with more than two copper layers, the head's point on every other layer (kind
  `ring`, in layer order): a `make_via` there puts a via at the head that takes it to that
  layer;
- then the current net's pads (pad order; a through-hole pad once per copper layer), its vias
  (once per layer) and its track ends, sorted by position;
deduplicated by (x, y, layer), the first kept, at most `max_candidates`.
"""
from __future__ import annotations

import math

from pcbdata.env.types import EMPTY, PAD, RING, TRACK_END, VIA, Candidate, Head, StaticBoard

DIRECTIONS = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))
RING_SLOTS = len(DIRECTIONS)
_EMPTY = Candidate(0, 0, 0, EMPTY)


def _snap(value: int, pitch: int, origin: int) -> int:
    return origin + round((value - origin) / pitch) * pitch


def ring(static: StaticBoard, head: Head | None, ring_nm: int) -> list[Candidate]:
    if head is None:
        return [_EMPTY] * RING_SLOTS
    if static.grid_pitch:
        pitch, origin = static.grid_pitch, static.grid_origin or 0
        x, y = _snap(head.x, pitch, origin), _snap(head.y, pitch, origin)
        return [Candidate(x + dx * pitch, y + dy * pitch, head.layer, RING)
                if dx == 0 or dy == 0 else _EMPTY for dx, dy in DIRECTIONS]
    diagonal = round(ring_nm / math.sqrt(2))
    out = []
    for dx, dy in DIRECTIONS:
        step = ring_nm if dx == 0 or dy == 0 else diagonal
        out.append(Candidate(head.x + dx * step, head.y + dy * step, head.layer, RING))
    return out


def layer_points(static: StaticBoard, head: Head | None) -> list[Candidate]:
    """The head's point on the other copper layers (boards with inner layers only: two-layer
    boards keep their candidate slots)."""
    if head is None or len(static.layers) <= 2:
        return []
    return [Candidate(head.x, head.y, layer, RING) for layer in range(len(static.layers))
            if layer != head.layer]


def net_points(static: StaticBoard, net: str, copper: list[dict]) -> list[Candidate]:
    """The net's pads, vias and track ends as candidates (before deduplication)."""
    points = [Candidate(p.x, p.y, layer, PAD) for p in static.pads if p.net == net
              for layer in p.layers]
    layer_index = {name: i for i, name in enumerate(static.layers)}
    vias = sorted((r["x"], r["y"]) for r in copper if r["net"] == net and r["kind"] == "via")
    points += [Candidate(x, y, layer, VIA) for x, y in vias for layer in range(len(static.layers))]
    ends = sorted({(layer_index[r["layer"]], *end) for r in copper
                   if r["net"] == net and r["kind"] != "via" for end in (r["start"], r["end"])})
    points += [Candidate(x, y, layer, TRACK_END) for layer, x, y in ends]
    return points


def candidates(static: StaticBoard, net: str | None, head: Head | None, copper: list[dict],
               ring_nm: int, limit: int) -> list[Candidate]:
    """The candidate list, padded with empty slots to exactly `limit` entries."""
    if net is None:
        return [_EMPTY] * limit
    out = ring(static, head, ring_nm)
    seen = {(c.x, c.y, c.layer) for c in out if c.kind != EMPTY}
    for point in layer_points(static, head) + net_points(static, net, copper):
        key = (point.x, point.y, point.layer)
        if key not in seen and len(out) < limit:
            seen.add(key)
            out.append(point)
    return out + [_EMPTY] * (limit - len(out))

"""Candidates (pure): ring order and geometry, D1 lattice, deduplication, limit, order."""
from __future__ import annotations

from pcbdata.env.candidates import candidates
from pcbdata.env.types import EMPTY, PAD, RING, TRACK_END, VIA, Head, NetRules, PadInfo, StaticBoard

MM = 1_000_000


def _static(pitch=None) -> StaticBoard:
    pads = (PadInfo("A", 10 * MM, 10 * MM, (MM, MM), "Circle", (0, 1), 600_000, "P1:1"),
            PadInfo("A", 20 * MM, 10 * MM, (MM, MM), "Rect", (0,), 0, "P2:1"),
            PadInfo("B", 30 * MM, 30 * MM, (MM, MM), "Rect", (1,), 0, "P3:1"))
    nets = (NetRules("A", 300_000, 300_000, 1_200_000, 600_000),
            NetRules("B", 300_000, 300_000, 1_200_000, 600_000))
    outline = (((0, 0), (50 * MM, 0), (50 * MM, 50 * MM), (0, 50 * MM)),)
    return StaticBoard("b", ("F.Cu", "B.Cu"), outline, nets, pads, (), (), 3, 300_000, pitch,
                       None if pitch is None else 3 * pitch // 4)


def test_no_head_lists_the_nets_points_after_empty_ring_slots():
    copper = [{"net": "A", "kind": "track", "layer": "F.Cu", "start": (20 * MM, 10 * MM),
               "end": (15 * MM, 10 * MM), "width": 1},
              {"net": "A", "kind": "via", "x": 15 * MM, "y": 10 * MM},
              {"net": "B", "kind": "via", "x": 40 * MM, "y": 40 * MM}]
    out = candidates(_static(), "A", None, copper, MM // 2, 16)
    assert len(out) == 16 and all(c.kind == EMPTY for c in out[:8])
    listed = [(c.x // MM, c.y // MM, c.layer, c.kind) for c in out[8:] if c.kind != EMPTY]
    # pads (the drilled one on both layers), vias on both layers; both track ends coincide
    # with a pad or a via and are deduplicated away
    assert listed == [(10, 10, 0, PAD), (10, 10, 1, PAD), (20, 10, 0, PAD), (15, 10, 0, VIA),
                      (15, 10, 1, VIA)]


def test_ring_is_octilinear_and_ordered():
    out = candidates(_static(), "A", Head(10 * MM, 10 * MM, 0), [], MM // 2, 64)
    ring = out[:8]
    assert all(c.kind == RING and c.layer == 0 for c in ring)
    steps = [((c.x - 10 * MM), (c.y - 10 * MM)) for c in ring]
    assert steps[0] == (MM // 2, 0) and steps[2] == (0, MM // 2) and steps[6] == (0, -MM // 2)
    assert all(dx == 0 or dy == 0 or abs(dx) == abs(dy) for dx, dy in steps)


def test_d1_ring_is_four_way_on_the_lattice():
    pitch = 10 * MM
    out = candidates(_static(pitch), "A", Head(7_500_000, 7_500_000, 0), [], MM // 2, 64)
    used = [c for c in out[:8] if c.kind == RING]
    assert [(c.x, c.y) for c in used] == [(17_500_000, 7_500_000), (7_500_000, 17_500_000),
                                          (-2_500_000, 7_500_000), (7_500_000, -2_500_000)]


def test_deduplication_and_limit():
    copper = [{"net": "A", "kind": "track", "layer": "F.Cu", "start": (10 * MM, 10 * MM),
               "end": (12 * MM, 10 * MM), "width": 1}]
    out = candidates(_static(), "A", None, copper, MM // 2, 64)
    keys = [(c.x, c.y, c.layer) for c in out if c.kind != EMPTY]
    assert len(keys) == len(set(keys))
    assert (12 * MM, 10 * MM, 0) in keys and [c.kind for c in out if c.kind == TRACK_END]
    assert len(candidates(_static(), "A", None, copper, MM // 2, 9)) == 9

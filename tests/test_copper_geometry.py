"""Arc length from three points and the file's own copper, without KiCad
(pcbdata.core.copper_geometry, pcbdata.core.copper_text)."""
from __future__ import annotations

import math

import pytest

from pcbdata.core.copper_geometry import arc_length, arc_polyline, items_outside, outline_shape
from pcbdata.core.copper_text import copper_in_file, file_problems, top_level_blocks

MM = 1_000_000


def test_a_colinear_arc_measures_as_its_segment():
    a, b = (10 * MM, 10 * MM), (110 * MM, 37 * MM)
    assert arc_length(a, (60 * MM, 23_500_000), b) == math.dist(a, b)
    # the midpoint rounded to the nanometre: a radius of kilometres, still the chord
    near = arc_length((0, 0), (50_000_001, 0), (100_000_000, 1))
    assert near == pytest.approx(math.dist((0, 0), (100_000_000, 1)), abs=1e-6 * MM)


@pytest.mark.parametrize("sagitta_nm", [1, 10, 1000, 10**5, 10**7])
def test_a_flat_arc_is_radius_times_angle(sagitta_nm):
    # a chord of 100 mm with a small sagitta s: r = (c^2/4 + s^2) / (2 s), angle 4 atan(2 s / c)
    c, s = 100 * MM, sagitta_nm
    expected = (c * c / 4 + s * s) / (2 * s) * 4 * math.atan2(2 * s, c)
    assert arc_length((0, 0), (c // 2, s), (c, 0)) == pytest.approx(expected, rel=1e-12)


def test_curved_arcs():
    assert arc_length((10 * MM, 10 * MM), (30 * MM, 30 * MM), (50 * MM, 10 * MM)) == (
        pytest.approx(20 * math.pi * MM, rel=1e-14))
    assert arc_length((1000, 0), (-1000, 0), (0, 1000)) == pytest.approx(1500 * math.pi)
    assert arc_length((1000, 0), (0, 1000), (-1000, 0)) == pytest.approx(1000 * math.pi)


def test_degenerate_arcs():
    assert arc_length((0, 0), (5, 0), (0, 0)) == pytest.approx(5 * math.pi)  # KiCad: a circle
    assert arc_length((0, 0), (5, 0), (3, 0)) == 7  # no arc through them: the path
    assert arc_length((0, 0), (0, 0), (0, 0)) == 0


def test_arc_polyline_follows_the_arc():
    points = arc_polyline((1000, 0), (-1000, 0), (0, 1000), 1)
    assert points[0] == (1000, 0) and points[-1] == pytest.approx((0, 1000), abs=1e-9)
    assert all(math.hypot(x, y) == pytest.approx(1000) for x, y in points)
    assert min(y for _, y in points) == pytest.approx(-1000, abs=1)  # the long way round


def test_items_outside_the_outline():
    square = [([(0, 0), (10 * MM, 0), (10 * MM, 10 * MM), (0, 10 * MM)], [])]
    board = outline_shape(square, MM)
    items = [{"kind": "track", "start": [MM, MM], "end": [9 * MM, MM]},
             {"kind": "track", "start": [MM, MM], "end": [10_500_000, MM]},  # within the margin
             {"kind": "track", "start": [MM, MM], "end": [12 * MM, MM]},
             {"kind": "via", "at": [-2 * MM, 0]},
             {"kind": "arc", "start": [MM, 5 * MM], "mid": [5 * MM, 14 * MM],
              "end": [9 * MM, 5 * MM]}]
    assert items_outside(items, board, 1000) == [2, 3, 4]


BOARD = b"""(kicad_pcb (version 20241229)
  (gr_text "(segment (layer \\"F.Cu\\"))" (at 1 1))
  (segment (start 1 2) (end 3 4) (width 0.3) (layer "F.Cu") (net 1))
  (arc (start 1 2) (mid 2 2.5) (end 3 2) (width 0.3) (layer Dwgs.User) (net 1))
  (via blind (at -1e9 5) (size 1.2) (drill 0.6) (layers "F.Cu" "B.Cu") (net 1)
    (padstack (mode custom) (layer "F.Mask" (size 1))))
  (footprint "x" (pad "1" smd rect (at 0 0) (layer "F.Cu")))
)
"""


def test_the_file_s_own_copper():
    heads = [head for head, _, _ in top_level_blocks(BOARD)]
    assert heads == ["version", "gr_text", "segment", "arc", "via", "footprint"]
    items = copper_in_file(BOARD)
    assert [(i["kind"], i["layers"]) for i in items] == [
        ("track", ["F.Cu"]), ("arc", ["Dwgs.User"]), ("via", ["F.Cu", "B.Cu"])]
    assert items[1]["points"] == {"start": [1, 2], "mid": [2, 2.5], "end": [3, 2]}
    assert file_problems(items, {"F.Cu", "B.Cu"}) == [
        "via at (-1e+09, 5) mm has a coordinate outside KiCad's range (+-2147.48 mm)",
        "arc at (1, 2) mm is on a layer the instance has no copper on (Dwgs.User)"]

"""The walkaround screen's closed-form ray entries (`pcbdata.router.ray_screen`) against
shapely's exact distances: a ray's bound is where it first comes within the radius of a core."""

import math

import numpy as np
import shapely

from pcbdata.router.clearance import HEADINGS
from pcbdata.router.ray_screen import CapsuleScreen, core_pieces


def _cores(rng: np.random.Generator) -> list[shapely.Geometry]:
    """Points, segments, polylines, rotated rectangles and a polygon with a hole (nm)."""
    cores: list[shapely.Geometry] = []
    for _ in range(12):
        x, y = rng.uniform(0, 40e6, 2)
        cores.append(shapely.Point(x, y))
        dx, dy = rng.uniform(-8e6, 8e6, 2)
        cores.append(shapely.LineString([(x, y), (x + dx, y + dy)]))
        box = shapely.box(x, y, x + rng.uniform(0.2e6, 3e6), y + rng.uniform(0.2e6, 3e6))
        cores.append(shapely.affinity.rotate(box, rng.uniform(0, 180)))
    cores.append(shapely.LineString([(1e6, 1e6), (5e6, 2e6), (5e6, 9e6), (9e6, 12e6)]))
    cores.append(shapely.Polygon([(20e6, 20e6), (30e6, 20e6), (30e6, 30e6), (20e6, 30e6)],
                                 [[(23e6, 23e6), (27e6, 23e6), (27e6, 27e6), (23e6, 27e6)]]))
    cores.append(shapely.MultiPolygon([shapely.box(0, 35e6, 1e6, 36e6),
                                       shapely.box(2e6, 35e6, 3e6, 36e6)]))
    return cores


def _screen(cores, radii) -> CapsuleScreen:
    pieces = [core_pieces(c) for c in cores]
    radius = np.repeat(radii, [len(p) for p in pieces])
    return CapsuleScreen(np.concatenate(pieces), radius)


def test_entries_are_where_a_ray_first_comes_within_the_radius():
    rng = np.random.default_rng(7)
    cores = _cores(rng)
    radii = rng.uniform(0.1e6, 1.5e6, len(cores))
    screen = _screen(cores, radii)
    points = rng.uniform(-5e6, 45e6, (400, 2))
    directions = HEADINGS[rng.integers(0, 8, len(points))]
    length = 30e6
    entries = screen.entries(points, directions, length)
    hits = np.isfinite(entries)
    assert 50 < hits.sum() < len(points)  # the sample has both kinds
    keepouts = shapely.buffer(np.array(cores, dtype=object), radii, quad_segs=256)
    union = shapely.union_all(keepouts)
    for p, d, t in zip(points, directions, entries):
        ray = shapely.LineString([p, p + d * length])
        if not math.isfinite(t):
            # No entry: the ray stays out of every keep-out (the fine polygons are inscribed,
            # so this is exact up to their ~r * 5e-6 chord error).
            assert not ray.intersects(shapely.buffer(union, -10.0))
            continue
        assert 0.0 <= t <= length
        # Just beyond the entry the ray is within the radius of some core...
        beyond = shapely.Point(p + d * (t + 1.0))
        assert any(shapely.distance(beyond, c) <= r + 1.0 for c, r in zip(cores, radii))
        # ...and before it, farther than the radius from every core, unless it starts inside
        # a polygon (then the bound is where it nears the boundary: longer, still sound).
        inside_polygon = any(c.contains(shapely.Point(p)) for c in cores)
        if t > 2.0 and not inside_polygon:
            before = shapely.LineString([p, p + d * (t - 2.0)])
            assert all(shapely.distance(before, c) > r - 1.0 for c, r in zip(cores, radii))


def test_a_ray_starting_inside_a_keepout_has_no_room():
    screen = _screen([shapely.Point(0, 0), shapely.LineString([(10e6, 0), (20e6, 0)])],
                     np.array([1e6, 1e6]))
    points = np.array([(0.5e6, 0), (15e6, 0.9e6), (15e6, 1.1e6)])
    entries = screen.entries(points, HEADINGS[[2, 2, 6]], 10e6)
    assert entries[0] == 0 and entries[1] == 0
    assert math.isclose(entries[2], 0.1e6, rel_tol=1e-9)  # heading 6 points down (-y)


def test_a_ray_along_a_track_enters_at_its_round_end():
    screen = _screen([shapely.LineString([(10e6, 0), (20e6, 0)])], np.array([1e6]))
    entry = screen.entries(np.array([(0.0, 0.0)]), HEADINGS[[0]], 50e6)[0]
    assert math.isclose(entry, 9e6, rel_tol=1e-12)
    grazing = screen.entries(np.array([(0.0, 1e6 + 5)]), HEADINGS[[0]], 50e6)[0]
    assert math.isinf(grazing)  # passes 5 nm outside the side


def test_core_pieces_of_each_kind():
    assert core_pieces(shapely.Point(3, 4)).tolist() == [[[3, 4], [3, 4]]]
    assert len(core_pieces(shapely.LineString([(0, 0), (1, 0), (1, 1)]))) == 2
    ring_with_hole = shapely.Polygon([(0, 0), (4, 0), (4, 4), (0, 4)],
                                     [[(1, 1), (2, 1), (2, 2), (1, 2)]])
    assert len(core_pieces(ring_with_hole)) == 8
    assert len(core_pieces(shapely.GeometryCollection([shapely.Point(0, 0),
                                                       shapely.box(0, 0, 1, 1)]))) == 5

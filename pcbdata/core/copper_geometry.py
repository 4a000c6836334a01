"""Geometry of copper items from their defining points (integer nm): arc length, arc polylines,
and whether items lie inside a board outline. Pure (standard library, shapely); no KiCad.

KiCad's `PCB_ARC.GetLength()` is wrong for nearly straight arcs (radius above about a metre):
an honest segment rewritten as an arc through its midpoint measured half its length. The
evaluator therefore measures every arc from its three points here.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

Point = Sequence[float]  # integer nm for copper (exact there); mm floats for outlines
Ring = Sequence[Point]


def _float(point: Point) -> tuple[float, float]:
    return float(point[0]), float(point[1])


def _cross_dot(start: Point, mid: Point, end: Point) -> tuple[float, float]:
    """Cross and dot product of (start - mid) and (end - mid), exact on integers."""
    ax, ay = start[0] - mid[0], start[1] - mid[1]
    bx, by = end[0] - mid[0], end[1] - mid[1]
    return ax * by - ay * bx, ax * bx + ay * by


def arc_length(start: Point, mid: Point, end: Point) -> float:
    """Length of the circular arc from `start` through `mid` to `end`, in their unit.

    radius * angle = a b c / (2 |cross|) * 2 atan2(|cross|, -dot), with a, b the distances
    from `mid` to the ends, c the chord; written as a b c * atan2(|cross|, -dot) / |cross|, which
    stays exact as the arc flattens (the quotient tends to 1 / (a b), the length to c).
    Points on one line: the chord when `mid` lies between the ends; a full circle of diameter
    |start - mid| when the ends coincide (as KiCad draws it); otherwise no arc passes through
    them and the path start-mid-end is measured (never shorter than any copper they span).
    """
    cross, dot = _cross_dot(start, mid, end)
    a = math.dist(start, mid)
    b = math.dist(mid, end)
    c = math.dist(start, end)
    if cross == 0:
        if dot <= 0:
            return c
        if c == 0:
            return math.pi * a
        return a + b
    return a * b * c * math.atan2(abs(cross), -dot) / abs(cross)


def _circle(start: Point, mid: Point, end: Point) -> tuple[float, float, float]:
    """(centre x, centre y, radius) of the circle through three points not on one line."""
    ax, ay = start[0] - mid[0], start[1] - mid[1]
    bx, by = end[0] - mid[0], end[1] - mid[1]
    d = 2.0 * (ax * by - ay * bx)
    a2, b2 = ax * ax + ay * ay, bx * bx + by * by
    ux = (by * a2 - ay * b2) / d
    uy = (ax * b2 - bx * a2) / d
    return mid[0] + ux, mid[1] + uy, math.hypot(ux, uy)


def arc_polyline(start: Point, mid: Point, end: Point,
                 tolerance: float) -> list[tuple[float, float]]:
    """Points along the arc, no farther than `tolerance` from it (at most 1024 pieces)."""
    cross, dot = _cross_dot(start, mid, end)
    pts = [_float(p) for p in (start, mid, end)]
    if cross == 0 and not (dot > 0 and start[0] == end[0] and start[1] == end[1]):
        return pts  # a straight arc, or start-mid-end when no arc passes through them
    if cross == 0:  # a full circle through start and mid
        cx, cy = (start[0] + mid[0]) / 2, (start[1] + mid[1]) / 2
        radius, sweep = math.dist(start, mid) / 2, 2 * math.pi
    else:
        cx, cy, radius = _circle(start, mid, end)
        sweep = 2 * math.atan2(abs(cross), -dot) * (1 if cross < 0 else -1)
    step = 2 * math.acos(max(-1.0, 1 - tolerance / radius)) if radius > tolerance else math.pi
    count = min(1024, max(2, math.ceil(abs(sweep) / max(step, 1e-9))))
    begin = math.atan2(start[1] - cy, start[0] - cx)
    return [(cx + radius * math.cos(begin + sweep * i / count),
             cy + radius * math.sin(begin + sweep * i / count)) for i in range(count + 1)]


def outline_shape(polygons: Sequence[tuple[Ring, Sequence[Ring]]], margin: float):
    """The board as a shapely geometry from (outer ring, holes) pairs, grown by `margin`."""
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    shape = unary_union([Polygon(outer, holes) for outer, holes in polygons if len(outer) >= 3])
    return shape.buffer(margin)


def item_path(item: dict, tolerance: float) -> list[tuple[float, float]]:
    """The centre line of a copper item (`kind` track / arc / via, points in nm)."""
    if item["kind"] == "via":
        return [_float(item["at"])]
    if item["kind"] == "arc":
        return arc_polyline(item["start"], item["mid"], item["end"], tolerance)
    return [_float(item["start"]), _float(item["end"])]


def items_outside(items: list[dict], board, tolerance: float) -> list[int]:
    """Indices of the items whose centre line leaves `board` (`outline_shape`)."""
    from shapely import prepared
    from shapely.geometry import LineString
    from shapely.geometry import Point as ShapelyPoint

    inside = prepared.prep(board)
    out = []
    for index, item in enumerate(items):
        path = item_path(item, tolerance)
        geometry = ShapelyPoint(path[0]) if len(path) == 1 else LineString(path)
        if not inside.covers(geometry):
            out.append(index)
    return out


def stub_cut(track: tuple[Point, Point], copper: dict) -> tuple[Point, tuple[int, int]] | None:
    """Where to shorten a track (start, end) one end of which touches nothing while its body
    crosses other copper of its net on its layer (`copper`: "segments" (a, b, radius),
    "circles" (centre, radius), "polygons" (rings), nm): (the end to keep, the new free end),
    the middle of the body's contact nearest the free end. None when both or neither end
    touch, or when the only contact is at the kept end (the track is a stub to delete whole)."""
    from shapely.geometry import LineString
    from shapely.geometry import Point as ShapelyPoint

    shape = _copper_shape(copper)
    touching = [shape.intersects(ShapelyPoint(_float(end))) for end in track]
    if touching.count(True) != 1:
        return None
    kept, free = (track[0], track[1]) if touching[0] else (track[1], track[0])
    line = LineString([_float(free), _float(kept)])
    contact = line.intersection(shape)
    pieces = getattr(contact, "geoms", [contact])
    spans = sorted((min(d), max(d)) for d in
                   ([line.project(ShapelyPoint(c)) for c in p.coords] for p in pieces
                    if not p.is_empty))
    if not spans or spans[0][1] >= line.length - 1.0:
        return None
    middle = line.interpolate(sum(spans[0]) / 2)
    return kept, (round(middle.x), round(middle.y))


def _copper_shape(copper: dict):
    from shapely.geometry import LineString, Polygon
    from shapely.geometry import Point as ShapelyPoint
    from shapely.ops import unary_union

    shapes = [(LineString([_float(a), _float(b)]) if tuple(a) != tuple(b)
               else ShapelyPoint(_float(a))).buffer(radius)
              for a, b, radius in copper.get("segments", [])]
    shapes += [ShapelyPoint(_float(c)).buffer(radius) for c, radius in copper.get("circles", [])]
    shapes += [Polygon(ring) for ring in copper.get("polygons", []) if len(ring) >= 3]
    return unary_union(shapes)

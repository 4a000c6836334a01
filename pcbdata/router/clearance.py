"""Clearance rules on one copper layer: items' exact shapes prepared for distance tests, the
layer's index of them, the rules a request keeps (`_Rules`: violations of segments, the ray
screen's bounds) and the board's region and edges. Shared by the walkaround router and its
search (`pcbdata.router.walkaround`, `pcbdata.router.search`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import shapely

from pcbdata.router import clearance_kernel
from pcbdata.router.clearance_kernel import GridIndex, core_kind
from pcbdata.router.ray_screen import CapsuleScreen, core_pieces

TOLERANCE = 1e-3  # nm: float rounding of distances (see the module doc); no margin is added
_ROOT2 = math.sqrt(2)
# Outward normals of the octagon's sides, counter-clockwise from +x.
_NORMALS = np.array([(math.cos(k * math.pi / 4), math.sin(k * math.pi / 4)) for k in range(8)])
# Corner k of an octagon is where side k meets side k+1: p = inverse(normals) @ (h_k, h_k+1).
_CORNER_SOLVERS = np.array(
    [np.linalg.inv(np.stack([_NORMALS[k], _NORMALS[(k + 1) % 8]])) for k in range(8)]
)
# Corner k lies between normals k and k+1; rounding it by these signs moves it away from both.
_CORNER_SIGNS = np.sign(
    [(math.cos((k + 0.5) * math.pi / 4), math.sin((k + 0.5) * math.pi / 4)) for k in range(8)]
)
_EDGE = "edge"
# Up to this many (segment, obstacle) pairs are screened all at once; more go through the
# layer's R-tree first.
_DENSE_PAIRS = 20_000
# Unit vectors of the eight octilinear headings (index k: k * 45 degrees) and the index of a
# heading given as a pair of signs, at [sx + 1, sy + 1].
HEADINGS = _NORMALS
_HEADING_INDEX = np.array([[5, 4, 3], [6, -1, 2], [7, 0, 1]])
# The windows of the nearby proof that two points are apart (`apart_nearby`), each tried in
# turn where the one before settles nothing: their half-sides, in multiples of the largest
# distance an obstacle's core keeps from the track's centre.
LOCAL_WINDOWS = (10.0, 30.0)
# Keep-outs for the ray screen (see `_Rules.free`): the allowed distance less this much (nm),
# so whatever they touch violates the clearance beyond float doubt.
_SCREEN_SHRINK = 1.0


# --- obstacles -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Prepared:
    """Per-item data that does not depend on the request; cached across `update` calls."""

    core: shapely.Geometry
    radius: float
    support: tuple[float, ...]  # max of normal_k . p over the core, k = 0..7
    inner: tuple[float, float]  # a point of the core
    convex: bool

    @cached_property
    def pieces(self) -> np.ndarray:
        """(k, 2, 2): the core's straight pieces, for the ray screen (only large searches
        use it, hence on demand)."""
        return core_pieces(self.core)

    @cached_property
    def kind(self) -> int:
        """The core's kind for the compiled test (`clearance_kernel.core_kind`)."""
        return core_kind(self.core)


def _prepare(core: shapely.Geometry, radius: float) -> _Prepared:
    coords = shapely.get_coordinates(core)
    support = tuple(float(s) for s in (coords @ _NORMALS.T).max(axis=0))
    inner = shapely.get_coordinates(shapely.point_on_surface(core))[0]
    convex = not isinstance(core, shapely.Polygon) or core.area >= 0.999 * core.convex_hull.area
    return _Prepared(core, radius, support, (float(inner[0]), float(inner[1])), convex)


class _Layer:
    """Obstacles on one copper layer (items and board-edge segments) as parallel arrays."""

    def __init__(self, records: list[tuple[str, str, int, _Prepared]]):
        # records: (kind, net, clearance, prepared); net "" and edges are obstacles to every net.
        # Net codes are the layer's own, so that a layer depends on its records alone.
        nets = sorted({r[1] for r in records} - {""})
        net_codes = {"": 0, **{net: i for i, net in enumerate(nets, start=1)}}
        self.net_codes = net_codes
        self.kind = [r[0] for r in records]
        self.net = [r[1] for r in records]
        self.code = np.array(
            [-1 if r[0] == _EDGE else net_codes[r[1]] for r in records], dtype=np.int64
        )
        self.is_edge = np.array([r[0] == _EDGE for r in records], dtype=bool)
        self.clearance = np.array([r[2] for r in records], dtype=float)
        prepared = [r[3] for r in records]
        self.cores = np.array([p.core for p in prepared], dtype=object)
        self.radius = np.array([p.radius for p in prepared], dtype=float)
        self.support = np.array([p.support for p in prepared], dtype=float).reshape(-1, 8)
        self.inner = np.array([p.inner for p in prepared], dtype=float).reshape(-1, 2)
        self.convex = np.array([p.convex for p in prepared], dtype=bool)
        self._prepared = prepared

    @cached_property
    def bounds(self) -> np.ndarray:
        """(n, 4): each core's box (xmin, ymin, xmax, ymax)."""
        return np.asarray(shapely.bounds(self.cores), dtype=float).reshape(-1, 4)

    @cached_property
    def tree(self) -> shapely.STRtree:
        """The cores in an R-tree, for the reference clearance test (built when that first
        runs: the compiled test has its own grid)."""
        return shapely.STRtree(self.cores)

    @cached_property
    def pieces(self) -> tuple[np.ndarray, np.ndarray]:
        """Every item's straight pieces (k, 2, 2) and the item each belongs to."""
        pieces = [p.pieces for p in self._prepared]
        owner = np.repeat(np.arange(len(pieces)), [len(p) for p in pieces])
        return np.concatenate(pieces or [np.empty((0, 2, 2))]), owner

    @cached_property
    def grid(self) -> GridIndex:
        """The layer's cores for the compiled clearance test (`pcbdata.router.clearance_kernel`)."""
        pieces, owner = self.pieces
        return GridIndex(pieces, owner, np.array([p.kind for p in self._prepared], np.int8))

    def describe(self, index: int) -> str:
        if self.kind[index] == _EDGE:
            return "the board edge"
        net = self.net[index]
        return f"a {self.kind[index]} of net {net!r}" if net else f"a no-net {self.kind[index]}"


def parts_apart(parts: list[np.ndarray], spots: np.ndarray, a: tuple[int, int],
                a_layers: list[int], b: tuple[int, int], b_layers: list[int]) -> bool:
    """Whether no clear way joins point a, on any of `a_layers`, to point b, on any of
    `b_layers`: `parts[k]` is layer k's free space in parts (`_Rules.free_parts`), and the
    parts of several layers that one of `spots` (a via's place) lies in are joined. Every way
    runs inside one part per layer and changes layer at a spot, so True is certain; False
    where in doubt (an end in no part, e.g. within a keep-out, proves nothing)."""
    joined = _JoinedParts(parts, spots)
    starts, goals = joined.holding(a, a_layers), joined.holding(b, b_layers)
    return bool(starts and goals) and not starts & goals


def layers_apart(rules: list[_Rules], region: shapely.Geometry | None, spots: np.ndarray,
                 a: tuple[int, int], a_layers: list[int], b: tuple[int, int],
                 b_layers: list[int]) -> bool:
    """`parts_apart` over the layers of `rules` (one request's, per layer: each layer's
    `free_parts`, joined through `spots`), settled first inside windows round the points
    (`apart_nearby`, the same answer where it answers) unless every layer's free space is at
    hand already. The walkaround search's proof (one layer, no spots) and the layered
    search's."""
    if any(r._free_parts is None for r in rules):
        nearby = apart_nearby(rules, region, spots, a, a_layers, b, b_layers)
        if nearby is not None:
            return nearby
    return parts_apart([r.free_parts(region) for r in rules], spots, a, a_layers, b, b_layers)


def apart_nearby(rules: list[_Rules], region: shapely.Geometry | None, spots: np.ndarray,
                 a: tuple[int, int], a_layers: list[int], b: tuple[int, int],
                 b_layers: list[int]) -> bool | None:
    """`parts_apart` over the layers of `rules` (one request's, per layer) from the free
    space inside a window round one point, or None where that does not settle it.

    The free space of a layer inside a window is the board there less the keep-outs of the
    obstacles that reach into it (`_Rules._free_near`); a part of it that does not reach the
    window's edge is a whole part of the layer's free space (nothing outside the window joins
    it). Parts joined inside the window are joined on the whole layers: where those joined to
    the point's parts (through the spots, on any layer) hold the other point on one of its
    layers, the points are not apart. Where every part joined to the point's parts is a whole
    part, those parts are exactly the point's in `parts_apart`: the points are apart, provided
    the other point is in the free space at all (its own window says), as `parts_apart` has
    it. With the same keep-outs, the same answer. The windows (`LOCAL_WINDOWS`) are tried
    from the smallest, each where the one before settles nothing."""
    if not any(r.obstacles for r in rules):
        return None
    need = max(r.max_need for r in rules)
    for size in LOCAL_WINDOWS:
        answer = _apart_within(rules, region, spots, a, a_layers, b, b_layers, size * need)
        if answer is not None:
            return answer
    return None


def _apart_within(rules: list[_Rules], region: shapely.Geometry | None, spots: np.ndarray,
                  a: tuple[int, int], a_layers: list[int], b: tuple[int, int],
                  b_layers: list[int], reach: float) -> bool | None:
    """`apart_nearby` inside windows of half-side `reach`."""

    def near(point: tuple[int, int]) -> tuple[shapely.Geometry, list[np.ndarray]]:
        frees = [r._free_near(region, point, reach) for r in rules]
        return frees[0][0], [parts for _, parts in frees]

    for p, p_layers, q, q_layers in ((a, a_layers, b, b_layers), (b, b_layers, a, a_layers)):
        window, parts = near(p)
        lo, hi = np.array(p) - reach, np.array(p) + reach
        inside = (np.all((spots >= lo) & (spots <= hi), axis=1) if len(spots)
                  else np.zeros(0, dtype=bool))
        joined = _JoinedParts(parts, spots[inside])
        starts = joined.holding(p, p_layers)
        if not starts:
            continue
        mine = [np.flatnonzero(np.isin(joined.roots(k), list(starts)))
                for k in range(len(parts))]
        if any(shapely.covers(parts[k][mine[k]], shapely.Point(q)).any() for k in q_layers):
            return False  # joined inside the window, so joined on the whole layers
        if any(shapely.intersects(parts[k][m], window.exterior).any()
               for k, m in enumerate(mine)):
            continue
        return any(bool(shapely.covers(near(q)[1][k], shapely.Point(q)).any())
                   for k in q_layers)
    return None


class _JoinedParts:
    """Free-space parts of several layers (`parts[k]`: layer k's), those that one of `spots`
    lies in joined (a union-find over all layers' parts, numbered layer by layer)."""

    def __init__(self, parts: list[np.ndarray], spots: np.ndarray):
        self.parts = parts
        self.offsets = np.cumsum([0] + [len(p) for p in parts])
        self.root = np.arange(self.offsets[-1])
        if len(spots):
            points = shapely.points(np.asarray(spots, dtype=float))
            pairs = []
            for k, layer_parts in enumerate(parts):
                spot, part = shapely.STRtree(layer_parts).query(points, predicate="covered_by")
                pairs.append(np.stack([spot, part + self.offsets[k]], axis=1))
            joined = np.concatenate(pairs)
            joined = joined[np.lexsort((joined[:, 1], joined[:, 0]))]
            for (spot_a, part_a), (spot_b, part_b) in zip(joined, joined[1:]):
                if spot_a == spot_b:
                    self.root[self.find(int(part_a))] = self.find(int(part_b))

    def find(self, x: int) -> int:
        root = self.root
        while root[x] != x:
            root[x] = root[root[x]]
            x = int(root[x])
        return x

    def holding(self, point: tuple[int, int], layers: list[int]) -> set[int]:
        """The roots of the parts that hold `point` on these layers."""
        return {self.find(int(self.offsets[k] + j)) for k in layers
                for j in np.flatnonzero(shapely.covers(self.parts[k], shapely.Point(point)))}

    def roots(self, k: int) -> np.ndarray:
        """The root of each of layer k's parts."""
        return np.array([self.find(int(self.offsets[k] + j)) for j in range(len(self.parts[k]))],
                        dtype=np.int64)


class _Rules:
    """One request's view of a layer: which items are obstacles and how far to stay away.

    `need` is the smallest allowed distance from our centreline to an item's core. The
    octagon `reach` (support + need in the 8 directions) contains everything closer, so a
    segment wholly beyond one of its sides is clear without an exact test.
    """

    def __init__(
        self,
        layer: _Layer,
        net_code: int,
        half_width: float,
        clearance: float,
        edge_clearance: float,
    ):
        self.layer = layer
        self.half_width, self.clearance = half_width, clearance
        obstacle = layer.is_edge | (layer.code <= 0) | (layer.code != net_code)
        gap = np.where(layer.is_edge, edge_clearance, np.maximum(clearance, layer.clearance))
        need = layer.radius + half_width + gap - TOLERANCE
        # Indexed by layer item; items of our own net get an empty reach (never checked).
        self.obstacle = obstacle
        self.need = np.where(obstacle, need, -np.inf)
        self.reach = layer.support + self.need[:, None]
        self.max_need = float(need[obstacle].max()) if obstacle.any() else 0.0
        self.obstacles = int(obstacle.sum())
        self._obstacle_items = np.flatnonzero(obstacle)
        self._obstacle_reach = self.reach[self._obstacle_items]
        self._screen: CapsuleScreen | None = None
        self._free_parts: np.ndarray | None = None  # `separated`'s free space, in parts
        # the free space inside windows (`_free_near`), by (point, half-side)
        self._free_windows: dict[tuple[tuple[int, int], float],
                                 tuple[shapely.Geometry, np.ndarray]] = {}
        # Kept for later searches under the same rules (see `WalkaroundRouter._rules`): the
        # search's corner nodes and ray bounds by (x, y, heading).
        self.corners: np.ndarray | None = None
        self.rays: dict[tuple[int, int, int], float] = {}
        self.ray_reach = 0.0
        self.layer_name = ""  # the layer these rules are for (`WalkaroundRouter._seed_rays`)
        # A router's rules (`WalkaroundRouter._rules`): the layer's state and the request's
        # net, whose corner nodes may follow from an earlier state's (`pcbdata.router.corners`).
        self.state: Any = None
        self.net = ""

    def free(self, points: np.ndarray, headings: np.ndarray, length: float) -> np.ndarray:
        """How far a track may run from each point along its heading (index into `HEADINGS`)
        at most: beyond it the track certainly violates clearance; up to it, it may or may not.

        The bound is where the ray enters a keep-out drawn inside the true one (see
        `_SCREEN_SHRINK`), so a segment longer than it fails for sure: the search uses it to
        skip the exact test of links that cannot be clear. `length`: the rays' reach (nm)."""
        screen = self._capsules()
        out = np.full(len(points), np.inf)
        if not len(screen):
            return out
        if clearance_kernel.enabled():  # compiled rays stop at their first entry anyway
            return screen.entries(points, HEADINGS[headings], length)
        # Short rays first: most meet a keep-out soon, and a short ray meets few.
        todo, reach = np.arange(len(points)), min(length, 4 * self.max_need)
        while len(todo):
            out[todo] = screen.entries(points[todo], HEADINGS[headings[todo]], reach)
            if reach >= length:
                break
            todo, reach = todo[np.isinf(out[todo])], min(length, 4 * reach)
        return out

    def _capsules(self) -> CapsuleScreen:
        if self._screen is None:
            pieces, owner = self.layer.pieces
            radius = self.need[owner] - _SCREEN_SHRINK
            keep = self.obstacle[owner] & (radius > 0)
            self._screen = CapsuleScreen(pieces[keep], radius[keep])
        return self._screen

    def violations(self, segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(segment, item) pairs closer than allowed, at least one per failing segment.

        segments: (k, 2, 2) float; a zero-length segment checks a dot of our width.
        """
        seg, item = self._near_pairs(segments)
        need = self.need[item]
        # Within reach of a point of the core: violating.
        hit = _point_segment_distance(self.layer.inner[item], segments[seg]) < need
        known = np.zeros(len(segments), dtype=bool)
        known[seg[hit]] = True
        bad_seg, bad_item = [seg[hit]], [item[hit]]
        # The rest: exact distance, for segments not already known to violate.
        unsure = ~hit & ~known[seg]
        if unsure.any():
            lines = _lines(segments[seg[unsure]])
            exact = shapely.distance(lines, self.layer.cores[item[unsure]]) < need[unsure]
            bad_seg.append(seg[unsure][exact])
            bad_item.append(item[unsure][exact])
        return np.concatenate(bad_seg), np.concatenate(bad_item)

    def _near_pairs(self, segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(segment, obstacle) pairs that no side of the obstacle's octagon separates."""
        obstacles = self._obstacle_items
        if not len(segments) or not len(obstacles):
            return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
        lowest = (segments @ _NORMALS.T).min(axis=1)  # (k, 8)
        if len(segments) * len(obstacles) <= _DENSE_PAIRS:
            near = ~(lowest[:, None, :] >= self._obstacle_reach[None]).any(axis=2)
            seg, j = np.nonzero(near)
            return seg, obstacles[j]
        lo, hi = segments.min(axis=1) - self.max_need, segments.max(axis=1) + self.max_need
        seg, item = self.layer.tree.query(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]))
        keep = self.obstacle[item]
        seg, item = seg[keep], item[keep]
        near = ~(lowest[seg] >= self.reach[item]).any(axis=1)
        return seg[near], item[near]

    def free_parts(self, region: shapely.Geometry | None) -> np.ndarray:
        """The free space of this request's track centre, in parts (polygons): the board
        `region` (None: no outline) less every obstacle's keep-out. Keep-outs are drawn inside
        the true ones (a buffer's polygon has its corners on the circle), so the space drawn
        is a little larger than the true one and every clear path lies in one part. Worked
        out once per rules (`separated`, `layered`'s proof that no way exists)."""
        if self._free_parts is None:
            items = self._obstacle_items
            blocked = self._keep_outs(items)
            if region is None:  # no outline: a box far round the keep-outs
                lo, hi = (np.array(shapely.bounds(blocked)).reshape(2, 2)
                          if len(items) else np.zeros((2, 2)))
                region = shapely.box(*(lo - 1e12), *(hi + 1e12))
            self._free_parts = shapely.get_parts(shapely.difference(region, blocked))
        return self._free_parts

    def _keep_outs(self, items: np.ndarray) -> shapely.Geometry:
        """The union of these layer records' keep-outs: each core buffered by its `need`."""
        return shapely.union_all(shapely.buffer(self.layer.cores[items], self.need[items],
                                                quad_segs=8))

    def separated(self, region: shapely.Geometry | None, a: tuple[int, int],
                  b: tuple[int, int]) -> bool:
        """Whether no clear path of this request's track joins points a and b on this layer
        (`layers_apart` on this layer alone: True only where certain)."""
        return layers_apart([self], region, np.empty((0, 2)), a, [0], b, [0])

    def _apart_nearby(self, region: shapely.Geometry | None, a: tuple[int, int],
                      b: tuple[int, int]) -> bool | None:
        """`separated` from the free space inside a window round one point, or None where
        that does not settle it (`apart_nearby` on this layer alone)."""
        return apart_nearby([self], region, np.empty((0, 2)), a, [0], b, [0])

    def _free_near(self, region: shapely.Geometry | None, p: tuple[int, int],
                   reach: float) -> tuple[shapely.Geometry, np.ndarray]:
        """A square window of half-side `reach` round `p` and the free space inside it, in
        parts (`free_parts` within the window; worked out once per rules, point and size)."""
        if (p, reach) in self._free_windows:
            return self._free_windows[p, reach]
        window = shapely.box(p[0] - reach, p[1] - reach, p[0] + reach, p[1] + reach)
        items = self._obstacle_items
        box, need = self.layer.bounds[items], self.need[items]
        near = ~((box[:, 2] + need < p[0] - reach) | (box[:, 0] - need > p[0] + reach)
                 | (box[:, 3] + need < p[1] - reach) | (box[:, 1] - need > p[1] + reach))
        area = window if region is None else shapely.intersection(region, window)
        free = window, shapely.get_parts(shapely.difference(area, self._keep_outs(items[near])))
        self._free_windows[p, reach] = free
        return free

    def failing(self, segments: np.ndarray) -> np.ndarray:
        """Whether each segment (k, 2, 2) violates clearance: by the compiled test where it is
        sure, else by `violations` (the same answers either way; `clearance_kernel`)."""
        if not clearance_kernel.enabled() or not len(segments) or not self.obstacles:
            return self._failing_exact(segments)
        status = self.layer.grid.judge(segments, self.need, self.max_need)
        bad = status == 1
        unsure = status == 2
        if unsure.any():
            bad[unsure] = self._failing_exact(segments[unsure])
        return bad

    def _failing_exact(self, segments: np.ndarray) -> np.ndarray:
        bad = np.zeros(len(segments), dtype=bool)
        bad[self.violations(segments)[0]] = True
        return bad


def _point_segment_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance from each point (p, 2) to its segment (p, 2, 2)."""
    a, ab = segments[:, 0], segments[:, 1] - segments[:, 0]
    ap = points - a
    length2 = np.maximum((ab * ab).sum(axis=1), 1e-12)
    t = np.clip((ap * ab).sum(axis=1) / length2, 0.0, 1.0)
    return np.hypot(*(ap - t[:, None] * ab).T)


def _lines(segments: np.ndarray) -> np.ndarray:
    """Shapely geometries of (k, 2, 2) segments; a zero-length segment becomes a point."""
    lines = shapely.linestrings(segments)
    dots = np.all(segments[:, 0] == segments[:, 1], axis=1)
    if dots.any():
        lines[dots] = shapely.points(segments[dots, 0])
    return lines


def _segments(path) -> np.ndarray:
    pts = np.asarray(path, dtype=float)
    return np.stack([pts[:-1], pts[1:]], axis=1) if len(pts) > 1 else pts[None, [0, 0]]


# --- the router ------------------------------------------------------------------------------


def _round_outwards(points: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """Rounds each coordinate to an integer in the direction of its sign (0: nearest). A
    value within a few `TOLERANCE` of an integer is that integer: a side at an exact integer
    sits `TOLERANCE` short of it in floats."""
    near = np.round(points)
    snapped = np.abs(points - near) <= 4 * TOLERANCE
    out = np.where(signs > 0, np.ceil(points), np.where(signs < 0, np.floor(points), near))
    return np.where(snapped, near, out)


def _board_region(outline) -> tuple[shapely.Geometry | None, list[shapely.Geometry]]:
    """The board area (rings inside the first are cut-outs, others add area) and its edges."""
    if not outline:
        return None, []
    region = shapely.make_valid(shapely.Polygon(outline[0]))
    for ring in outline[1:]:
        shape = shapely.make_valid(shapely.Polygon(ring))
        region = region.difference(shape) if region.contains(shape) else region.union(shape)
    edges = []
    for ring in outline:
        for a, b in zip(ring, ring[1:] + ring[:1]):
            if tuple(a) != tuple(b):
                edges.append(shapely.LineString([a, b]))
    shapely.prepare(region)  # many containment tests follow
    return region, edges

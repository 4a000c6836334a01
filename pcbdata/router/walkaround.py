"""Walkaround router: octilinear paths that keep clearance to other nets (SPEC section 6).

The environment's `walkaround` mode asks for a path from the head to a point on one copper
layer. KiCad stays the judge, so a path we return must pass KiCad's DRC by construction:
every segment keeps `max(request clearance, item clearance)` (copper edge to copper edge) from
every other net's copper on the layer and `edge_clearance` from the board edge, checked on the
integer path we return. The rule is KiCad's: a gap equal to the clearance is legal (D1 boards
route at exactly the clearance from the edge and from the next cell's pad). Distances are
floats: a gap counts as legal down to `TOLERANCE` (1e-3 nm) below the clearance, so float
rounding of an exactly-equal gap cannot refuse it; that is far below what KiCad's DRC lets
pass (it tests against the clearance minus a small epsilon and rounds to integer nm).
Corner nodes are rounded to integer nm away from their obstacle (see `_corner_nodes`).

Tries, cheapest first: the straight segment (when start-goal is octilinear), the two one-bend
paths, then a search. The search graph's nodes are the corners of octagonal keep-outs around
obstacles (edges at 0/45/90/135 degrees, so paths hug obstacles along octilinear lines) and
the inset board corners; two nodes are linked by a straight or one-bend octilinear path.
Expanding a node checks, in one batch, its links to every node whose cost they would lower.

Most of those links are blocked, so a cheap screen goes first: a ray from a node along a
heading meets a keep-out drawn just inside the true one (`_Rules.free`, worked out in closed
form over capsules by `ray_screen`); a link segment longer than that bound from either of its
node ends certainly violates and skips the exact test. The
screen only ever removes links that the exact test would refuse, so verdicts, paths and the
counted work (`checks` counts links asked, screened or not) are those of the exact test alone.
What a search works out is kept under the state it depends on (the request layer's items,
outline and edge clearance; `_Memory`): the layer's index, per net and width the keep-outs,
corner nodes and ray bounds, and whole answers, so a request asked again on an unchanged layer
(push_n_shove first retries the walkaround that just failed) costs nothing, and copper added on
one layer leaves the others' entries valid.

This module is the router's facade and its memory (`WalkaroundRouter`, `_Memory`); the request
and answer types are in `pcbdata.router.requests`, the clearance rules and a layer's index in
`pcbdata.router.clearance`, the search in `pcbdata.router.search`.
"""

from __future__ import annotations

import time
from bisect import bisect_left
from collections import Counter, OrderedDict
from collections.abc import Iterable
from dataclasses import replace

import numpy as np
import shapely

from pcbdata.router.clearance import (
    _CORNER_SIGNS,
    _CORNER_SOLVERS,
    _EDGE,
    _board_region,
    _Layer,
    _prepare,
    _Prepared,
    _round_outwards,
    _Rules,
    _segments,
)
from pcbdata.router.geometry import (
    BoardGeometry,
    CopperItem,
    Point,
    copper_core,
    item_sort_key,
    one_bend_paths,
)
from pcbdata.router.layered import LayeredRequest, LayeredResult, kept_off, route_layers
from pcbdata.router.requests import RouteRequest, RouteResult
from pcbdata.router.search import _mm, _Search
from pcbdata.router.soft import SoftCopper

# The search budget (see WalkaroundRouter): expansions and link checks.
BUDGET_NODES = 20_000
BUDGET_CHECKS = 400_000


class WalkaroundRouter:
    """Plans octilinear paths on a snapshot of the board; make a new one (or `update`) after
    every copper change.

    A search stops after `budget_nodes` expansions or `budget_checks` link checks, counts that
    do not depend on the machine, so the same board and request give the same answer anywhere.
    `budget_seconds` (default None: no limit) adds a wall-clock limit, at the price of that.
    With `prove_separation`, a search that has come far asks once whether its ends lie in
    separate parts of the free space and stops if they do (`search.SEPARATION_AFTER`): the
    same paths, less work where none exists.
    """

    def __init__(
        self,
        board: BoardGeometry,
        budget_nodes: int = BUDGET_NODES,
        budget_checks: int = BUDGET_CHECKS,
        budget_seconds: float | None = None,
        prove_separation: bool = False,
    ):
        self.budget_nodes = budget_nodes
        self.budget_checks = budget_checks
        self.budget_seconds = budget_seconds
        self.prove_separation = prove_separation
        self._cache: dict[CopperItem, _Prepared] = {}
        self._shared = _Memory()
        # the last board's items, sorted, and counted (`_sorted_copper`)
        self._sorted: tuple[list[CopperItem], Counter[CopperItem]] | None = None
        self.update(board)

    def with_board(self, board: BoardGeometry) -> WalkaroundRouter:
        """A router for another board (e.g. with items taken out or added), with this one's
        budgets and prepared shapes (this router is unchanged)."""
        other = WalkaroundRouter.__new__(WalkaroundRouter)
        other.budget_nodes, other.budget_checks = self.budget_nodes, self.budget_checks
        other.budget_seconds = self.budget_seconds
        other.prove_separation = self.prove_separation
        other._cache = dict(self._cache)
        other._shared = self._shared
        other._sorted = self._sorted
        other.update(board)
        return other

    def update(self, board: BoardGeometry) -> None:
        """Takes a new board snapshot; items seen before reuse their prepared shapes, and the
        outline's region and edges are kept while the outline and edge clearance stay."""
        old = getattr(self, "board", None)
        self.board = board
        items, came, went = self._sorted_copper(board.copper)
        if came is None or went is None:  # a board of its own: its items' shapes only
            self._cache = {item: self._cache.get(item) or self._shape(item) for item in items}
        else:  # the last board's, less the items gone, with those come
            for item in went:
                self._cache.pop(item, None)
            for item in came:
                if item not in self._cache:
                    self._cache[item] = self._shape(item)
        same_edges = old is not None and old.edge_clearance == board.edge_clearance and (
            old.outline is board.outline or old.outline == board.outline)
        if not same_edges:
            self._region, edges = _board_region(board.outline)
            self._edge_records = [(_EDGE, "", board.edge_clearance, _prepare(e, 0.0))
                                  for e in edges]
            self._inset_corners: dict[float, np.ndarray] = {}
        self._layer_items: dict[str, list[CopperItem]] = {}
        for item in items:
            for layer in item.layers:
                self._layer_items.setdefault(layer, []).append(item)
        self._keys: dict[str, _StateKey] = {}

    def _sorted_copper(self, copper: tuple[CopperItem, ...]
                       ) -> tuple[list[CopperItem], Iterable[CopperItem] | None,
                                  Iterable[CopperItem] | None]:
        """`sorted(copper, key=item_sort_key)`, from the last board's sorted items where the
        two share most of them (a planner adds and takes up a few at a time): the last list
        less the items gone, the new ones put in their places. The key is every field, so
        items with one key are equal and the list is the same (repeated items, e.g. one via
        of two wires, side by side). Also the items come and gone since the last board (None,
        None: sorted afresh)."""
        counts = Counter(copper)
        last, self._sorted = self._sorted, None
        if last is not None:
            old_list, old_counts = last
            if len(counts) == len(copper) and len(old_counts) == len(old_list):
                added = dict.fromkeys(counts.keys() - old_counts.keys(), 1)  # each once
            else:
                added = counts - old_counts
            if sum(added.values()) <= len(copper) // 4 + 16:
                went = old_counts.keys() - counts.keys()
                if went or len(old_list) + sum(added.values()) != len(copper):
                    out, left = [], dict(counts)
                    for item in old_list:
                        if left.get(item, 0) > 0:
                            left[item] -= 1
                            out.append(item)
                else:
                    out = list(old_list)
                for item in sorted(added, key=item_sort_key):
                    at = bisect_left(out, item_sort_key(item), key=item_sort_key)
                    out[at:at] = [item] * added[item]
                self._sorted = (out, counts)
                return out, added.keys(), went
        out = sorted(copper, key=item_sort_key)
        self._sorted = (out, counts)
        return out, None, None

    def prepared(self, item: CopperItem) -> _Prepared:
        """`item`'s prepared shape: the board's, else worked out once and remembered with the
        routers made from this one (`_Memory.PREPARED` items at most; a planner's copper that
        comes and goes, e.g. soft copper, `pcbdata.router.soft`)."""
        shape = self._cache.get(item)
        if shape is not None:
            return shape
        memory = self._shared.prepared
        shape = memory.get(item)
        if shape is None:
            shape = memory[item] = _prepare(*copper_core(item))
            if len(memory) > _Memory.PREPARED:
                memory.popitem(last=False)
        else:
            memory.move_to_end(item)
        return shape

    def _shape(self, item: CopperItem) -> _Prepared:
        """A shape for an item coming onto the board: the one `prepared` remembers, else
        worked out (not remembered: the board keeps it)."""
        return self._shared.prepared.get(item) or _prepare(*copper_core(item))

    def _layer_key(self, layer: str) -> _StateKey:
        """What a layer's answers depend on: the board outline, the edge clearance and the
        layer's items. Layers, rules and routes are remembered under it (`_Memory`)."""
        if layer not in self._keys:
            self._keys[layer] = _StateKey(
                (self.board.outline, self.board.edge_clearance,
                 tuple(self._layer_items.get(layer, ())))
            )
        return self._keys[layer]

    # --- public checks ---

    def segment_is_clear(
        self, net: str, layer: str, a: Point, b: Point, width: int, clearance: int
    ) -> bool:
        """Whether a track a-b of this width keeps clearance to other nets and the edge."""
        if not self._inside(np.array([a], dtype=float))[0]:
            return False
        return not self._rules(net, layer, width, clearance).failing(_segments([a, b]))[0]

    def via_fits(
        self, net: str, at: Point, diameter: int, clearance: int, layers: tuple[str, ...]
    ) -> bool:
        """Whether a via of this diameter at `at` keeps clearance on every layer and to the edge."""
        return bool(self.vias_fit(net, [at], diameter, clearance, layers)[0])

    def vias_fit(
        self, net: str, points, diameter: int, clearance: int, layers: tuple[str, ...]
    ) -> np.ndarray:
        """`via_fits` for many points at once (one clearance check per layer). The net's own
        drilled copper (vias, pads on several layers) counts too: holes keep apart whatever
        their nets (KiCad's hole_to_hole), so a via may not overlap one."""
        at = np.asarray(points, dtype=float).reshape(-1, 2)
        fits = self._inside(at)
        dots = np.repeat(at[:, None, :], 2, axis=1)
        for layer in layers:
            if fits.any():
                fits &= ~self._rules(net, layer, diameter, clearance).failing(dots)
        if fits.any():
            fits[fits] = ~self._on_own_holes(net, at[fits], diameter)
        return fits

    def _on_own_holes(self, net: str, at: np.ndarray, diameter: int) -> np.ndarray:
        """Per point, whether a via of `diameter` there overlaps the net's own drilled copper.
        Each item is measured only against the points inside its box widened by that reach
        (a point outside is farther than the reach): the same answers."""
        drilled = [item for item in self.board.copper if item.net == net and (
            item.kind == "via" or (item.kind == "pad" and len(item.layers) > 1))]
        over = np.zeros(len(at), dtype=bool)
        for item in drilled:
            shape = self._cache[item]
            reach = shape.radius + diameter / 2
            x0, y0, x1, y1 = shapely.bounds(shape.core)
            near = np.flatnonzero((at[:, 0] >= x0 - reach) & (at[:, 0] <= x1 + reach)
                                  & (at[:, 1] >= y0 - reach) & (at[:, 1] <= y1 + reach))
            if len(near):
                over[near] |= shapely.distance(shape.core, shapely.points(at[near])) < reach
        return over

    # --- routing ---

    def route(self, request: RouteRequest) -> RouteResult:
        """A path for the request. An answer depends only on the request, the budgets and the
        request layer's state, so one asked again on an unchanged layer is remembered (unless
        a wall-clock limit makes answers depend on the machine)."""
        clock = time.perf_counter()
        key = None
        if self.budget_seconds is None:
            key = (self._layer_key(request.layer), request, self.budget_nodes, self.budget_checks)
            known = self._shared.routes.get(key)
            if known is not None:
                self._shared.routes.move_to_end(key)
                stats = {**known.stats, "seconds": time.perf_counter() - clock}
                return RouteResult(known.path, known.reason, stats)
        result = self._route(request, clock)
        self._shared.work += int(result.stats.get("checks", 0))
        if key is not None:
            kept = replace(result, stats=dict(result.stats))
            self._shared.remember(self._shared.routes, key, kept)
        result.stats["seconds"] = time.perf_counter() - clock
        return result

    def route_layers(self, request: LayeredRequest, soft: SoftCopper | None = None
                     ) -> LayeredResult:
        """A way over several layers with vias as moves of the search
        (`pcbdata.router.layered`), remembered like `route`'s answers under the state of every
        layer it may use; with `soft`, copper it may cross at a price (`pcbdata.router.soft`;
        not remembered)."""
        if soft is not None:
            result = route_layers(self, request, soft)
            self._shared.work += int(result.stats.get("checks", 0))
            return result
        key = (tuple(self._layer_key(lay) for lay in request.layers),
               replace(request, holes=()), kept_off(self, request),
               self.budget_nodes, self.budget_checks)
        known = self._shared.routes.get(key)
        if known is not None:
            self._shared.routes.move_to_end(key)
            return known
        result = route_layers(self, request)
        self._shared.work += int(result.stats.get("checks", 0))
        self._shared.remember(self._shared.routes, key, result)
        return result

    def _route(self, req: RouteRequest, clock: float) -> RouteResult:
        start, goal = (int(req.start[0]), int(req.start[1])), (int(req.goal[0]), int(req.goal[1]))
        if req.width <= 0 or req.clearance < 0:
            return RouteResult(
                None,
                f"invalid request: width {req.width} nm, clearance {req.clearance} nm",
                {"method": "none"},
            )
        rules = self._rules(req.net, req.layer, req.width, req.clearance)
        for name, point in (("start", start), ("goal", goal)):
            problem = self._point_problem(rules, point)
            if problem:
                return RouteResult(
                    None, f"{name} {_mm(point)} on {req.layer} {problem}", {"method": "none"}
                )
        if start == goal:
            return RouteResult((start,), "", {"method": "direct", "expanded": 0})
        for path in one_bend_paths(start, goal):
            if not rules.failing(_segments(path)).any():
                method = "direct" if len(path) == 2 else "two_segment"
                return RouteResult(tuple(path), "", {"method": method, "expanded": 0})
        return _Search(self, rules, start, goal, clock).run()

    # --- internals ---

    def _rules(self, net: str, layer: str, width: int, clearance: int) -> _Rules:
        key = self._layer_key(layer)
        rules_key = (key, net, width, clearance)
        memory = self._shared
        if rules_key in memory.rules:
            memory.rules.move_to_end(rules_key)
            return memory.rules[rules_key]
        if key not in memory.layers:
            records = [
                (item.kind, item.net, item.clearance, self._cache[item])
                for item in self._layer_items.get(layer, ())
            ]
            memory.remember(memory.layers, key, _Layer(records + self._edge_records))
        shape = memory.layers[key]
        memory.layers.move_to_end(key)
        code = shape.net_codes.get(net, -2)  # a net with no copper here owns nothing
        rules = _Rules(shape, code, width / 2, clearance, self.board.edge_clearance)
        rules.layer_name, rules.state, rules.net = layer, key, net
        self._seed_rays(rules, key, net, width, clearance)
        memory.remember(memory.rules, rules_key, rules)
        return rules

    def _seed_rays(self, rules: _Rules, key: _StateKey, net: str, width: int,
                   clearance: int) -> None:
        """Starts `rules` with the ray bounds of the latest remembered state of this layer that
        holds a subset of its items (same outline, same net and sizes). More copper only
        shortens a ray, so each old bound is still an upper bound and the screen still never
        rules out a clear link; where the new copper crosses a ray, it is only less tight.
        Answers are the same either way; rays are the screen's dearest part."""
        for (old_key, *sizes), old in reversed(self._shared.rules.items()):
            if (sizes != [net, width, clearance] or old.layer_name != rules.layer_name
                    or not old.rays or old_key.value[:2] != key.value[:2]):
                continue
            if old_key.items() <= key.items():
                rules.rays, rules.ray_reach = dict(old.rays), old.ray_reach
                return

    def _inside(self, points: np.ndarray) -> np.ndarray:
        if self._region is None:
            return np.ones(len(points), dtype=bool)
        return shapely.contains_xy(self._region, points[:, 0], points[:, 1])

    def _point_problem(self, rules: _Rules, point: Point) -> str:
        if not self._inside(np.array([point], dtype=float))[0]:
            return "is outside the board"
        dot = _segments([point])
        if not rules.failing(dot)[0]:  # the compiled test where it is sure: most points
            return ""
        _, items = rules.violations(dot)
        if len(items):
            return f"is within clearance of {rules.layer.describe(int(items.min()))}"
        return ""

    def _corner_nodes(self, rules: _Rules) -> np.ndarray:
        """Candidate nodes: octagon corners around obstacles and the inset board corners.

        The octagon's sides lie at exactly the allowed distance, so a link along a side keeps
        the clearance with nothing to spare; a corner is rounded to integer nm outwards (each
        coordinate away from the obstacle, in the quadrant between the corner's two normals),
        which keeps it outside both of its sides, hence at least `need` from the core.
        """
        return self._corner_candidates(rules, None)[0]

    def _corner_candidates(self, rules: _Rules, items: np.ndarray | None
                           ) -> tuple[np.ndarray, np.ndarray]:
        """`_corner_nodes` and the layer record each came from (-1: a board corner); with
        `items` (record indices of obstacles), those items' corners only."""
        layer = rules.layer
        board = items is None
        if items is None:
            items = np.flatnonzero(rules.obstacle & ~layer.is_edge)
        reach = rules.reach[items]
        pairs = np.stack([reach, np.roll(reach, -1, axis=1)], axis=2)  # (m, 8, 2)
        corners = np.einsum("kij,mkj->mki", _CORNER_SOLVERS, pairs)  # (m, 8, 2)
        parts = [_round_outwards(corners, _CORNER_SIGNS[None]).reshape(-1, 2)]
        owners = [np.repeat(items, 8)]
        for i in items[~layer.convex[items]]:  # octagons lose a zone's bays: add its own corners
            grown = shapely.buffer(layer.cores[i], rules.need[i], join_style="mitre")
            points = shapely.get_coordinates(shapely.boundary(grown))
            parts.append(_round_outwards(points, np.sign(points - layer.inner[i])))
            owners.append(np.full(len(points), i))
        if board:
            parts.append(self._board_corners(rules.half_width))
            owners.append(np.full(len(parts[-1]), -1))
        return (np.concatenate(parts).reshape(-1, 2),
                np.concatenate(owners).astype(np.int64))

    def _board_corners(self, half_width: float) -> np.ndarray:
        """Corners of the board inset by the edge clearance, rounded towards the board's
        inside (nodes that still fail the edge test are dropped with the others)."""
        if self._region is None:
            return np.empty((0, 2))
        if half_width not in self._inset_corners:
            inset = shapely.buffer(
                self._region, -(half_width + self.board.edge_clearance), join_style="mitre"
            )
            if inset.is_empty:
                points = np.empty((0, 2))
            else:
                points = shapely.get_coordinates(shapely.boundary(inset))
                centre = shapely.get_coordinates(shapely.centroid(inset))[0]
                points = _round_outwards(points, np.sign(centre - points))
            self._inset_corners[half_width] = points
        return self._inset_corners[half_width]


class _StateKey:
    """A large hashable value with its hash worked out once (a layer's items)."""

    __slots__ = ("value", "hash", "_items")

    def __init__(self, value: tuple):
        self.value, self.hash = value, hash(value)
        self._items: frozenset | None = None

    def items(self) -> frozenset:
        """The layer's items (the last part of the value), as a set, worked out once."""
        if self._items is None:
            self._items = frozenset(self.value[2])
        return self._items

    def __hash__(self) -> int:
        return self.hash

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, _StateKey) and self.hash == other.hash and self.value == other.value
        )


class _Memory:
    """What a router and the routers made from it (`with_board`) remember between searches,
    each under the state it was worked out for, so a copper change on one layer leaves the
    others' entries valid. Least recently used entries go first."""

    LAYERS, RULES, ROUTES = 8, 32, 256
    PREPARED = 100_000

    def __init__(self) -> None:
        self.layers: OrderedDict = OrderedDict()
        self.rules: OrderedDict = OrderedDict()
        self.routes: OrderedDict = OrderedDict()
        self.vias: OrderedDict = OrderedDict()  # via candidates (`layered.via_candidates`)
        #: Recent states' corner nodes by layer, outline, width and clearance
        #: (`pcbdata.router.corners`), most recent first.
        self.corner_sets: OrderedDict = OrderedDict()
        #: Prepared shapes of items off the routers' boards (`WalkaroundRouter.prepared`).
        self.prepared: OrderedDict = OrderedDict()
        #: Link checks made by searches worked out (not remembered) so far: the routers'
        #: counted work, which a caller may budget (`pcbdata.router.negotiate`).
        self.work = 0

    def remember_corners(self, group: tuple, corner_set, kept: int) -> None:
        """Keeps `corner_set` first in its group, at most `kept` a group and `RULES` groups."""
        sets = [corner_set] + [c for c in self.corner_sets.pop(group, []) if c is not corner_set]
        self.corner_sets[group] = sets[:kept]
        while len(self.corner_sets) > self.RULES:
            self.corner_sets.popitem(last=False)

    def remember(self, table: OrderedDict, key, value) -> None:
        table[key] = value
        limit = {id(self.layers): self.LAYERS, id(self.rules): self.RULES,
                 id(self.vias): self.RULES}.get(
            id(table), self.ROUTES
        )
        while len(table) > limit:
            table.popitem(last=False)

"""A search over every copper layer at once, with vias as moves inside it (`route_layers`).

The graph's nodes are, per layer, the two ends, the walkaround search's octagon corners for
the request's track (`pcbdata.router.search`) and the via candidates; a via candidate is one
node per layer, and a move between two of them (same point, another layer) is a via. Via
candidates are the corners of the keep-outs for a dot of the via's diameter on every layer
and rings of spots around both ends, those where a via fits (`WalkaroundRouter.vias_fit`: every
layer, the edge, the net's own drilled copper) and off the request's `holes` (drilled copper of
the net that the router's board lacks). Links on a layer are the walkaround search's
(straight or one-bend octilinear, checked exactly, screened by ray bounds), so every leg keeps
clearance by construction, and every via fits where it stands.

A* over all layers (a via costs `via_cost` nm of track; the heuristic, the octilinear distance
to the goal, weighted by the request's `heuristic_weight`), inside a window around the ends that
grows while it holds no way; an expansion checks links to its `LINKS` nearest nodes and the
goal (far links on a crowded board are nearly all blocked); the budget counts expansions and
link checks as the walkaround search does. The answer is legs (layer, octilinear path) joined
by vias, or None with the reason.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pcbdata.router import clearance_kernel
from pcbdata.router.clearance import HEADINGS, layers_apart
from pcbdata.router.corners import corner_nodes, unique_points
from pcbdata.router.geometry import Point, simplify_path
from pcbdata.router.search import (
    SEPARATION_AFTER,
    WINDOW_MIN,
    WINDOW_SHARE,
    _link_segments,
    _octilinear_to,
    _pick,
    _Search,
    _targets,
)
from pcbdata.router.soft import SoftCopper, SoftLayer

#: What a via costs in the search, in nm of track.
VIA_COST = 2_000_000
#: Links checked per expansion at most: to the nearest nodes (and the goal).
LINKS = 128
#: Ring distances of via spots around an end, in units of (end reach + via radius + clearance).
RING_STEPS = (1.0, 1.5, 2.2)


@dataclass(frozen=True)
class LayeredRequest:
    net: str
    start: Point
    start_layers: tuple[str, ...]
    goal: Point
    goal_layers: tuple[str, ...]
    width: int
    clearance: int
    via_diameter: int
    layers: tuple[str, ...]  # the layers the search may use (a via spans all of them)
    reach: tuple[int, int] = (0, 0)  # how far the ends' copper reaches (for via rings)
    via_cost: int = VIA_COST
    #: Drilled copper of the request's net that the router's board lacks, (point, diameter):
    #: no via spot overlaps one (KiCad's hole_to_hole; a spot on its very point is the same
    #: via, reused).
    holes: tuple[tuple[Point, int], ...] = ()
    #: The weight of the A* heuristic (the octilinear distance to the goal): 1 finds the
    #: cheapest way; more expands fewer nodes for a way at most that many times as dear (the
    #: planner's repair uses it for its layered searches: the prices of its rip-up searches
    #: make the distance a weak guide).
    heuristic_weight: float = 1.0


@dataclass(frozen=True)
class LayeredResult:
    legs: tuple[tuple[str, tuple[Point, ...]], ...] | None  # None: no way
    vias: tuple[Point, ...] = ()
    reason: str = ""
    stats: dict = field(default_factory=dict)


def via_candidates(router, req: LayeredRequest) -> np.ndarray:
    """(n, 2) int64 via spots that fit for this request, sorted (remembered per board state),
    none over the request's `holes`."""
    points = _fitting_spots(router, req)
    if len(points) and req.holes:
        points = points[~over_holes(points, req.holes, req.via_diameter)]
    return points


def kept_off(router, req: LayeredRequest) -> tuple[Point, ...]:
    """The via spots that fit the board but that the request's `holes` keep the search off
    (what the holes change of the search: none, and it is the search without them)."""
    if not req.holes:
        return ()
    points = _fitting_spots(router, req)
    off = points[over_holes(points, req.holes, req.via_diameter)] if len(points) else points
    return tuple((int(x), int(y)) for x, y in off)


def _fitting_spots(router, req: LayeredRequest) -> np.ndarray:
    key = (tuple(router._layer_key(lay) for lay in req.layers), req.net, req.via_diameter,
           req.clearance, req.start, req.goal, req.reach)
    memory = router._shared.vias
    if len(req.layers) < 2:
        return np.empty((0, 2), np.int64)
    if key in memory:
        memory.move_to_end(key)
        return memory[key]
    parts = [_dot_corners(router, req, layer) for layer in req.layers]
    for end, reach in ((req.start, req.reach[0]), (req.goal, req.reach[1])):
        unit = reach + req.via_diameter / 2 + req.clearance
        for step in RING_STEPS:
            parts.append(np.rint(np.array(end) + HEADINGS * unit * step))
    points = unique_points(np.concatenate(parts))
    points = points[~((points == req.start).all(axis=1) | (points == req.goal).all(axis=1))]
    if len(points):
        points = points[router.vias_fit(req.net, points, req.via_diameter, req.clearance,
                                        req.layers)]
    router._shared.remember(memory, key, points)
    return points


def over_holes(points: np.ndarray, holes, diameter: int) -> np.ndarray:
    """Per point, whether a via of `diameter` there overlaps one of `holes` ((point,
    diameter) pairs) without standing on its very point."""
    at = np.array([h[0] for h in holes], dtype=float)
    reach = np.array([h[1] for h in holes], dtype=float) / 2 + diameter / 2
    gap = np.hypot(points[:, None, 0] - at[None, :, 0], points[:, None, 1] - at[None, :, 1])
    return ((gap > 0) & (gap < reach[None, :])).any(axis=1)


def _dot_corners(router, req: LayeredRequest, layer: str) -> np.ndarray:
    rules = router._rules(req.net, layer, req.via_diameter, req.clearance)
    return corner_nodes(router, rules).astype(float)


class _LayerGraph(_Search):
    """One layer's nodes (start, goal, corners, vias in the window) with the walkaround
    search's link checks (`_Search._links_clear`) and shortcuts."""

    def __init__(self, router, rules, points: np.ndarray, reach: float, compiled: bool):
        self.router, self.rules, self.clock = router, rules, 0.0
        self.compiled = compiled  # the expansions' work compiled (`search_kernel`)
        self.checks = self.expanded = self.screened = self.ruled_out = 0
        self.points = points.astype(float)  # for the ray bounds
        self.nodes, self.rows = points.astype(np.int64), np.arange(len(points))
        self.free = np.full((len(points), 8), np.nan)
        if reach > rules.ray_reach:  # kept bounds may be infinite only for want of reach
            rules.rays.clear()
            rules.ray_reach = 2 * reach
        self.reach = rules.ray_reach


class _Layered:
    def __init__(self, router, req: LayeredRequest, soft: SoftCopper | None = None):
        self.router, self.req = router, req
        self.rules = [router._rules(req.net, lay, req.width, req.clearance)
                      for lay in req.layers]
        self.corners = [corner_nodes(router, r) for r in self.rules]
        self.soft: list[SoftLayer] = []
        if soft is not None:
            self._take_soft(soft)
        ends = np.array([req.start, req.goal], dtype=np.int64)
        self.corners = [c[~(c[:, None, :] == ends[None]).all(axis=2).any(axis=1)]
                        for c in self.corners]
        self.vias = via_candidates(router, req)
        self.via_prices = np.zeros(len(self.vias))
        if soft is not None and len(self.vias):
            dots = np.repeat(self.vias[:, None, :].astype(float), 2, axis=1)
            for lay in req.layers:
                spans = SoftLayer(router, soft, req.net, lay, req.via_diameter, req.clearance)
                self.via_prices += spans.prices(dots)
        self.ends = ends
        every = np.concatenate([ends, self.vias, *self.corners]).astype(float)
        self.reach = float(np.hypot(*(every.max(axis=0) - every.min(axis=0)))) + 2.0
        self.expanded = self.checks = 0
        self.asked = False  # whether the search asked `_separated` yet
        self.starts = [k for k, lay in enumerate(req.layers) if lay in req.start_layers
                       and not router._point_problem(self.rules[k], req.start)]
        self.goals = [k for k, lay in enumerate(req.layers) if lay in req.goal_layers
                      and not router._point_problem(self.rules[k], req.goal)]

    def _take_soft(self, soft: SoftCopper) -> None:
        """Soft copper per layer, and the corners of its keep-outs as more nodes (those clear
        of the hard copper), so that a way may also go round it."""
        req, router = self.req, self.router
        for k, lay in enumerate(req.layers):
            layer = SoftLayer(router, soft, req.net, lay, req.width, req.clearance)
            self.soft.append(layer)
            if layer.empty:
                continue
            more = router._corner_nodes(layer.rules)
            more = more[router._inside(more)] if len(more) else more
            if len(more):
                more = more[~self.rules[k].failing(np.stack([more, more], axis=1))]
                self.corners[k] = unique_points(np.concatenate(
                    [self.corners[k], more.astype(np.int64)]))

    def run(self) -> LayeredResult:
        if not self.starts or not self.goals:
            return self._fail("an end is within clearance of other copper on its layers")
        lo, hi = self.ends.min(axis=0), self.ends.max(axis=0)
        margin = max(WINDOW_MIN, WINDOW_SHARE * float((hi - lo).max()))
        while True:
            inside = [np.all((c >= lo - margin) & (c <= hi + margin), axis=1)
                      for c in [self.vias, *self.corners]]
            result = self._astar([c[m] for c, m in zip(self.corners, inside[1:])],
                                 self.vias[inside[0]], self.via_prices[inside[0]])
            if result is not None:
                return result
            if all(m.all() for m in inside):
                return self._fail("no way on any layer")
            if self._over_budget():
                return self._fail("no way within the search budget")
            margin *= 2

    def _over_budget(self) -> bool:
        return (self.expanded >= self.router.budget_nodes
                or self.checks >= self.router.budget_checks)

    def _astar(self, corners: list[np.ndarray], vias: np.ndarray,
               via_prices: np.ndarray) -> LayeredResult | None:
        """A way through these nodes, a failed result when out of budget, None when none."""
        graphs, offsets, size = [], [], 0
        compiled = clearance_kernel.enabled()
        for k, rules in enumerate(self.rules):
            points = np.concatenate([self.ends, vias, corners[k]])
            graphs.append(_LayerGraph(self.router, rules, points, self.reach, compiled))
            offsets.append(size)
            size += len(points)
        nvias = len(vias)
        layer_of = np.repeat(np.arange(len(graphs)), [len(g.points) for g in graphs])
        g = np.full(size, np.inf)
        parent = np.full(size, -1, dtype=np.int64)
        closed = np.zeros(size, dtype=bool)
        heuristic = np.concatenate([_octilinear_to(gr.nodes, self.req.goal) for gr in graphs])
        if self.req.heuristic_weight != 1.0:
            heuristic = heuristic * self.req.heuristic_weight
        goal_nodes = {offsets[k] + 1 for k in self.goals}
        for k in self.starts:
            g[offsets[k]] = 0.0
        try:
            while True:
                u = _pick(g, heuristic, closed, compiled)
                if u < 0:
                    return None
                if self._over_budget():
                    return self._fail("no way within the search budget")
                if self._separated():
                    return self._fail("no way: the free space joins no part holding the start "
                                      "to one holding the goal")
                closed[u] = True
                self.expanded += 1
                if u in goal_nodes:
                    return self._finish(graphs, offsets, layer_of, parent, u)
                k = int(layer_of[u])
                self._expand(k, graphs[k], offsets[k], u - offsets[k], g, parent, closed)
                local = u - offsets[k]
                if 2 <= local < 2 + nvias:  # a via to the same spot on the other layers
                    cost = g[u] + self.req.via_cost + via_prices[local - 2]
                    for j, off in enumerate(offsets):
                        w = off + local
                        if j != k and not closed[w] and cost < g[w]:
                            g[w], parent[w] = cost, u
        finally:
            self.checks += sum(gr.checks for gr in graphs)

    def _separated(self) -> bool:
        """Whether no way can exist, asked once, after `SEPARATION_AFTER` link checks, where
        the router asks for it (`WalkaroundRouter.prove_separation`): each layer's free space
        (`_Rules.free_parts`, hard copper only: soft copper is crossed, never in the way),
        joined through the via spots, keeps the start apart from the goal
        (`clearance.layers_apart`: settled first inside windows round the ends where it can
        be)."""
        if self.asked or self.checks < SEPARATION_AFTER or not self.router.prove_separation:
            return False
        self.asked = True
        return layers_apart(self.rules, self.router._region, self.vias, self.req.start,
                            self.starts, self.req.goal, self.goals)

    def _expand(self, k: int, graph: _LayerGraph, offset: int, i: int, g, parent,
                closed) -> None:
        span = slice(offset, offset + len(graph.nodes))
        targets, cost = _targets(graph.nodes, i, g[span], closed[span], graph.compiled)
        if len(targets) > LINKS:  # the nearest, and the goal: far links are mostly blocked
            near = np.lexsort((targets, cost))[:LINKS]
            if 1 in targets[:2] and 1 not in targets[near]:  # the goal (targets are sorted)
                near = np.append(near, 0 if targets[0] == 1 else 1)
            near = np.sort(near)  # targets are sorted: positions in order are targets in order
            targets, cost = targets[near], cost[near]
        if not len(targets):
            return
        before = graph.checks
        priced = bool(self.soft) and not self.soft[k].empty
        variants = graph._links_clear(i, targets)
        clear = variants.any(axis=0)
        reached = targets[clear]
        self.checks += graph.checks - before
        graph.checks = before
        new = cost[clear]
        if priced:
            new = new + self._link_prices(k, graph, i, reached, variants[:, clear])[0]
            better = new < g[offset + reached]
            reached, new = reached[better], new[better]
        g[offset + reached] = new
        parent[offset + reached] = offset + i

    def _link_prices(self, k: int, graph: _LayerGraph, i: int, targets: np.ndarray,
                     clear: np.ndarray | None = None):
        """Per target, the lower price of the two link variants from node i (inf where a
        variant is blocked by hard copper) and which variant that is. `clear` (2, n), where
        the expansion knows it already (`_Search._links_clear`): whether each variant is
        clear of hard copper; only those variants' segments are priced (a segment's price
        does not depend on the others), the same prices for less work."""
        a, ends = graph.nodes[i].astype(float), graph.nodes[targets].astype(float)
        prices = np.full((2, len(targets)), np.inf)
        for variant in (0, 1):
            segments, owner = _link_segments(a, ends, variant)
            self.checks += len(segments)
            if clear is None:
                hard = graph.rules.failing(segments)
                blocked = np.bincount(owner, weights=hard, minlength=len(targets)) > 0
            else:
                blocked = ~clear[variant]
            open_ = ~blocked[owner]
            paid = np.zeros(len(segments))
            if open_.any():
                paid[open_] = self.soft[k].prices(segments[open_])
            total = np.bincount(owner, weights=paid, minlength=len(targets)).astype(float)
            total[blocked] = np.inf
            prices[variant] = total
        return prices.min(axis=0), prices.argmin(axis=0)
    def _finish(self, graphs, offsets, layer_of, parent, u: int) -> LayeredResult:
        chain = [u]
        while parent[chain[-1]] >= 0:
            chain.append(int(parent[chain[-1]]))
        chain.reverse()
        legs, vias, run = [], [], [chain[0]]
        for a, b in zip(chain, chain[1:]):
            if layer_of[a] != layer_of[b]:
                legs.append(run)
                run = [b]
                vias.append(b)
            else:
                run.append(b)
        legs.append(run)
        out = []
        for leg in legs:
            k = int(layer_of[leg[0]])
            graph = graphs[k]
            corners = tuple((int(x), int(y)) for x, y in
                            (graph.nodes[v - offsets[k]] for v in leg))
            if self.soft and not self.soft[k].empty:
                path = self._priced_leg(k, graph, leg, offsets[k], corners)
            else:
                path = graph._shortcut(corners) if len(corners) > 1 else corners
            self.checks += graph.checks
            graph.checks = 0
            if path is None or (len(path) > 1 and graph.rules.failing(
                    np.stack([np.array(path[:-1], float), np.array(path[1:], float)],
                             axis=1)).any()):
                return self._fail("internal error: a leg failed its final check")
            out.append((self.req.layers[k], tuple(path)))
        spots = tuple(out[i][1][-1] for i in range(len(out) - 1))
        if _too_close(spots, self.req.via_diameter + self.req.clearance):
            return self._fail("two vias of the way too close together")
        stats = {"method": "layered", "expanded": self.expanded, "checks": self.checks,
                 "vias": len(spots)}
        return LayeredResult(tuple(out), spots, "", stats)

    def _priced_leg(self, k, graph, leg, offset, corners):
        """The leg through the search's corners, each link the variant the search priced
        (no shortcuts: a shortcut could cross more soft copper)."""
        out = [corners[0]]
        for u, v, end in zip(leg, leg[1:], corners[1:]):
            price, variant = self._link_prices(k, graph, u - offset, np.array([v - offset]))
            if not np.isfinite(price[0]):
                return None
            out.extend(_variant(out[-1], end, int(variant[0])))
        return simplify_path(out)

    def _fail(self, reason: str) -> LayeredResult:
        return LayeredResult(None, (), reason, {"method": "layered", "expanded": self.expanded,
                                                "checks": self.checks})


def _variant(a: Point, b: Point, variant: int) -> list[Point]:
    """The points after a of link variant 0 (straight then 45 degrees) or 1 (45 degrees then
    straight) from a to b (`search._link_segments`)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    m = min(abs(dx), abs(dy))
    diag = ((m if dx > 0 else -m if dx < 0 else 0), (m if dy > 0 else -m if dy < 0 else 0))
    knee = (b[0] - diag[0], b[1] - diag[1]) if variant == 0 else (a[0] + diag[0],
                                                                   a[1] + diag[1])
    return [knee, b] if knee not in (a, b) else [b]


def _too_close(spots: tuple[Point, ...], gap: float) -> bool:
    return any((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 < gap * gap
               for i, a in enumerate(spots) for b in spots[i + 1:])


def route_layers(router, req: LayeredRequest, soft: SoftCopper | None = None) -> LayeredResult:
    """A way for the request over all its layers (see the module doc); `soft`: copper it may
    cross at a price (`pcbdata.router.soft`)."""
    if req.start == req.goal and set(req.start_layers) & set(req.goal_layers):
        layer = sorted(set(req.start_layers) & set(req.goal_layers))[0]
        return LayeredResult(((layer, (req.start,)),), (), "", {"method": "direct"})
    result = _Layered(router, req, soft).run()
    if result.legs is None:
        return result
    legs = tuple((layer, tuple(simplify_path(list(path))) if len(path) > 1 else path)
                 for layer, path in result.legs)
    return LayeredResult(legs, result.vias, "", result.stats)

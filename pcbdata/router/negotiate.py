"""Negotiated routing on plain geometry: every open connection of a board planned at once, with
rip-up and reroute, before any copper is laid.

Connections (`pcbdata.router.connections`): per net, a minimum spanning tree over its pad
clusters (Kruskal on the shortest pad-to-pad distance between two clusters), routed shortest
first. A connection is tried by the
walkaround router (`pcbdata.router.walkaround`) on a layer both ends are on, then through one
via (ends on different layers), then through two vias (a leg on another layer between two
vias, for ends on one side whose own layer is blocked); via spots are a ring around each end
and points along the straight line, those a via fits at (`vias_fit`) nearest the straight
line first.

A connection that finds no way is searched again on the board without the other connections'
planned copper (pads, zones, existing copper stay). If that finds a way, the connections whose
planned copper the way passes too close to are ripped up (exact distances, as push_n_shove's
blockers), the connection takes its way and the ripped ones are queued again ahead of the rest;
a connection is ripped at most `max_rips` times (then it is never a blocker again), so the loop
ends. A connection with no way even on the board without planned copper is *boxed in*; one
that has a way there but only through copper that may not be ripped is *congested*; one that
ran out of the budget is *budget*. The best state seen (most connections routed, then least
wire) is the plan. Work is counted in route calls (`budget_routes`), never timed: the same
board gives the same plan on any machine.

Every leg is a walkaround path and every via fits where it stands, so the planned copper
keeps clearance by construction; KiCad judges it when it is laid (`pcbdata.agents.negotiated`
lays it through the environment's free-coordinate actions). Nothing here imports KiCad.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np
import shapely

from pcbdata.router.clearance import HEADINGS, TOLERANCE
from pcbdata.router.connections import Connection, End
from pcbdata.router.geometry import BoardGeometry, CopperItem, Point, copper_core
from pcbdata.router.requests import RouteRequest
from pcbdata.router.walkaround import WalkaroundRouter

#: Route calls a plan may make (the budget), and rip-ups of one connection at most.
BUDGET_ROUTES = 3000
MAX_RIPS = 3
#: Via spots tried per layer change (nearest the straight line first), and per end for the
#: two-via way (each pair costs up to three route calls).
VIA_TRIES = 6
VIA_PAIR_TRIES = 3
#: Ring distances of via spots around an end, in units of (pad radius + via radius + clearance).
RING_STEPS = (1.0, 1.5, 2.2)
#: Spots along a guide path for a via (every GUIDE_STEP nm along octilinear steps), at most
#: GUIDE_TRIES of them tried.
GUIDE_STEP = 250_000
GUIDE_TRIES = 6
#: Rounds after the first, each with the connections left open placed first.
RESTARTS = 2
CAUSES = ("boxed_in", "congestion", "budget")


@dataclass(frozen=True)
class NetRule:
    width: int
    clearance: int
    via_diameter: int
    via_drill: int


@dataclass(frozen=True)
class Wire:
    """A planned connection: legs (layer, octilinear path) joined end to end by vias
    (`vias[i]` joins `legs[i]` and `legs[i + 1]`)."""

    net: str
    legs: tuple[tuple[str, tuple[Point, ...]], ...]
    vias: tuple[Point, ...] = ()

    def items(self, rule: NetRule, layers: tuple[str, ...]) -> list[CopperItem]:
        out = [CopperItem(kind="track", net=self.net, layers=(layer,), start=a, end=b,
                          width=rule.width, clearance=rule.clearance)
               for layer, path in self.legs for a, b in zip(path, path[1:]) if a != b]
        out += [CopperItem(kind="via", net=self.net, layers=layers, start=v, end=v,
                           width=rule.via_diameter, clearance=rule.clearance) for v in self.vias]
        return out

    @property
    def length(self) -> float:
        return math.fsum(math.hypot(b[0] - a[0], b[1] - a[1])
                         for _, path in self.legs for a, b in zip(path, path[1:]))


@dataclass
class Plan:
    wires: dict[int, Wire]  # by connection index
    open: dict[int, str]  # connection index -> cause (CAUSES)
    stats: dict = field(default_factory=dict)


class Negotiator:
    """Plans `connections` on `board` (see the module doc)."""

    def __init__(self, board: BoardGeometry, layers: tuple[str, ...],
                 rules: dict[str, NetRule], connections: list[Connection],
                 budget_routes: int = BUDGET_ROUTES, max_rips: int = MAX_RIPS,
                 restarts: int = RESTARTS, router_nodes: int | None = None,
                 router_checks: int | None = None):
        budgets = {k: v for k, v in (("budget_nodes", router_nodes),
                                     ("budget_checks", router_checks)) if v is not None}
        self.base, self.layers, self.rules = board, tuple(layers), rules
        self.connections = list(connections)
        self.budget, self.max_rips, self.restarts = budget_routes, max_rips, restarts
        self.bare = WalkaroundRouter(board, **budgets)  # the board without planned copper
        self.router = self.bare.with_board(board)  # with all of it
        self.fixed_router = self.bare.with_board(board)  # with what may not be ripped up
        self.calls = 0
        self._reset()

    def _reset(self) -> None:
        self.wires: dict[int, Wire] = {}
        self.items: dict[int, list[CopperItem]] = {}
        self.rips = [0] * len(self.connections)
        self._stale = self._fixed_stale = True

    # --- the loop ---

    def run(self) -> Plan:
        """Rounds of the negotiation: the first in the connections' order, each later one
        with the connections the best round left open first (their history), from a clean
        board; the best round is the plan."""
        order = list(range(len(self.connections)))
        best: Plan | None = None
        rounds = 0
        for _ in range(1 + self.restarts):
            plan = self._round(order)
            rounds += 1
            if best is None or _rank(plan) < _rank(best):
                best = plan
            if not best.open or self.calls >= self.budget:
                break
            first = sorted(best.open, key=lambda i: (self.connections[i].length, i))
            order = first + [i for i in order if i not in best.open]
        assert best is not None
        best.open = {i: self._cause(i, c) for i, c in sorted(best.open.items())}
        best.stats = {**best.stats, "route_calls": self.calls, "rounds": rounds,
                      "connections": len(self.connections)}
        return best

    def _round(self, order: list[int]) -> Plan:
        self._reset()
        queue = deque(order)
        failed: dict[int, str] = {}
        best: tuple | None = None
        while queue:
            index = queue.popleft()
            if index in self.wires:
                continue
            cause = self._place(index, queue)
            if cause:
                failed[index] = cause
            else:
                failed.pop(index, None)
            best = self._keep_best(best, failed)
        for index in [i for i in failed if i not in self.wires]:  # copper moved since
            if self.calls < self.budget and self._route_here(index):
                failed.pop(index)
                best = self._keep_best(best, failed)
        wires, open_ = (best[2], best[3]) if best else ({}, {})
        return Plan(dict(wires), dict(open_), {"rips": sum(self.rips)})

    def _cause(self, index: int, cause: str) -> str:
        """The cause of an open connection: `boxed_in` where even the board without planned
        copper has no way for it (a repeated request costs nothing: the router remembers)."""
        if cause == "budget" or self.calls >= self.budget:
            return cause
        return "boxed_in" if self._way(self.bare, index) is None else cause

    def _keep_best(self, best, failed):
        """The best state so far: fewest open connections, then least wire; a later state as
        good replaces an earlier one (it knows more causes). A connection open because it was
        ripped up and not yet placed again counts as congestion."""
        open_ = {i: failed.get(i, "congestion" if self.rips[i] else "budget")
                 for i in range(len(self.connections)) if i not in self.wires}
        key = (len(open_), math.fsum(w.length for w in self.wires.values()))
        if best is None or key <= best[:2]:
            return (*key, dict(self.wires), open_)
        return best

    def _place(self, index: int, queue: deque) -> str:
        """Routes connection `index` (ripping others up if that is the way); '' or a cause.
        The rip-up search sees the board without the planned copper that may still be ripped
        up (connections ripped `max_rips` times stay as obstacles)."""
        if self.calls >= self.budget:
            return "budget"
        if self._route_here(index):
            return ""
        wire = self._way(self._fixed(), index)
        if wire is None:
            return "budget" if self.calls >= self.budget else "congestion"
        blockers = self._blockers(index, wire)
        for b in blockers:
            self._drop(b)
            self.rips[b] += 1
            self._fixed_stale |= self.rips[b] >= self.max_rips
        self._add(index, wire)
        queue.extendleft(sorted(blockers, key=lambda b: (-self.rips[b], b), reverse=True))
        return ""

    def _route_here(self, index: int) -> bool:
        wire = self._way(self._router(), index)
        if wire is not None:
            self._add(index, wire)
        return wire is not None

    # --- the board's state ---

    def _router(self) -> WalkaroundRouter:
        if self._stale:
            copper = self.base.copper + tuple(i for items in self.items.values() for i in items)
            self.router.update(replace(self.base, copper=copper))
            self._stale = False
        return self.router

    def _fixed(self) -> WalkaroundRouter:
        """The router over the board and the planned copper that may not be ripped up."""
        if self._fixed_stale:
            fixed = tuple(i for k, items in self.items.items() if self.rips[k] >= self.max_rips
                          for i in items)
            self.fixed_router.update(replace(self.base, copper=self.base.copper + fixed))
            self._fixed_stale = False
        return self.fixed_router

    def _add(self, index: int, wire: Wire) -> None:
        self.wires[index] = wire
        self.items[index] = wire.items(self.rules[wire.net], self.layers)
        self._stale = True
        self._fixed_stale |= self.rips[index] >= self.max_rips

    def _drop(self, index: int) -> None:
        self.wires.pop(index, None)
        self.items.pop(index, None)
        self._stale = True

    def _blockers(self, index: int, wire: Wire) -> list[int]:
        """Planned connections of other nets whose copper is too close to `wire`'s."""
        net, rule = wire.net, self.rules[wire.net]
        mine = wire.items(rule, self.layers)
        shapes = [(i, *copper_core(i)) for i in mine]
        out = []
        for other, items in sorted(self.items.items()):
            if self.connections[other].net == net or self.rips[other] >= self.max_rips:
                continue
            if any(_too_close(a, ca, ra, b) for a, ca, ra in shapes for b in items):
                out.append(other)
        return out

    # --- ways ---

    def _way(self, router: WalkaroundRouter, index: int) -> Wire | None:
        c = self.connections[index]
        rule = self.rules[c.net]
        for layer in [lay for lay in self.layers if lay in c.a.layers and lay in c.b.layers]:
            path = self._leg(router, c.net, layer, c.a.at, c.b.at, rule)
            if path:
                return Wire(c.net, ((layer, path),))
        for la in [lay for lay in self.layers if lay in c.a.layers]:
            for lb in [lay for lay in self.layers if lay in c.b.layers and lay != la]:
                wire = self._one_via(router, c, la, lb, rule)
                if wire:
                    return wire
        for layer in [lay for lay in self.layers if lay in c.a.layers and lay in c.b.layers]:
            wire = self._two_vias(router, c, layer, rule)
            if wire:
                return wire
        return None

    def _leg(self, router, net, layer, a: Point, b: Point, rule: NetRule):
        if a == b:
            return (a,)
        if self.calls >= self.budget:
            return None
        self.calls += 1
        result = router.route(RouteRequest(net=net, layer=layer, start=a, goal=b,
                                           width=rule.width, clearance=rule.clearance))
        return None if result.path is None else tuple((int(x), int(y)) for x, y in result.path)

    def _one_via(self, router, c: Connection, la: str, lb: str, rule: NetRule) -> Wire | None:
        """a on `la`, a via, b on `lb`: vias at spots around the ends first, then along a guide
        path (a to b's place on `la`, via near b; a's place to b on `lb`, via near a), whose
        part up to (or from) the via is kept as one leg."""
        for v in self._spots(router, c, rule)[:VIA_TRIES]:
            first = self._leg(router, c.net, la, c.a.at, v, rule)
            if first is None:
                continue
            second = self._leg(router, c.net, lb, v, c.b.at, rule)
            if second is not None:
                return Wire(c.net, ((la, first), (lb, second)), (v,))
        guide = self._leg(router, c.net, la, c.a.at, c.b.at, rule)
        for head, v in self._guide_spots(router, c.net, guide, rule, from_end=True):
            second = self._leg(router, c.net, lb, v, c.b.at, rule)
            if second is not None:
                return Wire(c.net, ((la, head), (lb, second)), (v,))
        guide = self._leg(router, c.net, lb, c.a.at, c.b.at, rule)
        for tail, v in self._guide_spots(router, c.net, guide, rule, from_end=False):
            first = self._leg(router, c.net, la, c.a.at, v, rule)
            if first is not None:
                return Wire(c.net, ((la, first), (lb, tail)), (v,))
        return None

    def _guide_spots(self, router, net: str, guide, rule: NetRule, from_end: bool) -> list:
        """(part of `guide` up to the spot, or from it; the spot) for the via spots on the
        guide (`_cuts`), nearest the guide's end first (`from_end`) or its start; at most
        GUIDE_TRIES."""
        cuts = self._cuts(router, net, guide, rule)
        chosen = list(reversed(cuts)) if from_end else cuts
        out = []
        for _, k, point in chosen[:GUIDE_TRIES]:
            part = guide[:k + 1] + (point,) if from_end else (point,) + guide[k + 1:]
            out.append((part, point))
        return out

    def _cuts(self, router, net: str, guide, rule: NetRule) -> list:
        """Points on a guide path every GUIDE_STEP (exact octilinear steps) where a via fits,
        as (distance from the start, segment index, point), nearest the start first."""
        if not guide or len(guide) < 2:
            return []
        cuts = []
        run = 0.0
        for k, (a, b) in enumerate(zip(guide, guide[1:])):
            dx, dy = b[0] - a[0], b[1] - a[1]
            steps = max(abs(dx), abs(dy))
            if steps == 0:
                continue
            unit = (dx // steps if dx else 0, dy // steps if dy else 0)
            length = math.hypot(dx, dy)
            for n in range(GUIDE_STEP, steps, GUIDE_STEP):
                cuts.append((run + length * n / steps, k, (a[0] + unit[0] * n,
                                                           a[1] + unit[1] * n)))
            run += length
        if not cuts:
            return []
        fits = router.vias_fit(net, [p for _, _, p in cuts], rule.via_diameter, rule.clearance,
                               self.layers)
        return [cut for cut, ok in zip(cuts, fits) if ok]

    def _guided_two_vias(self, router, c: Connection, layer: str, middle_layer: str,
                         rule: NetRule) -> Wire | None:
        """a and b on `layer`, the way between them on `middle_layer`: a guide path from a's
        place to b's there, a via on it near each end, short legs on `layer` to the vias."""
        guide = self._leg(router, c.net, middle_layer, c.a.at, c.b.at, rule)
        cuts = self._cuts(router, c.net, guide, rule)
        half = GUIDE_TRIES // 2
        for d1, k1, p1 in cuts[:half]:
            first = self._leg(router, c.net, layer, c.a.at, p1, rule)
            if first is None:
                continue
            for d2, k2, p2 in list(reversed(cuts))[:half]:
                if d2 <= d1:
                    continue
                last = self._leg(router, c.net, layer, p2, c.b.at, rule)
                if last is not None:
                    middle = (p1, *guide[k1 + 1:k2 + 1], p2)
                    return Wire(c.net, ((layer, first), (middle_layer, middle),
                                        (layer, last)), (p1, p2))
        return None

    def _two_vias(self, router, c: Connection, layer: str, rule: NetRule) -> Wire | None:
        others = [lay for lay in self.layers if lay != layer]
        if not others:
            return None
        for middle_layer in others:
            wire = self._guided_two_vias(router, c, layer, middle_layer, rule)
            if wire:
                return wire
        near_a = self._spots(router, c, rule, c.a)[:VIA_PAIR_TRIES]
        near_b = self._spots(router, c, rule, c.b)[:VIA_PAIR_TRIES]
        for va in near_a:
            first = self._leg(router, c.net, layer, c.a.at, va, rule)
            if first is None:
                continue
            for vb in near_b:
                if vb == va:
                    continue
                for middle_layer in others:
                    middle = self._leg(router, c.net, middle_layer, va, vb, rule)
                    if middle is None:
                        continue
                    last = self._leg(router, c.net, layer, vb, c.b.at, rule)
                    if last is not None:
                        return Wire(c.net, ((layer, first), (middle_layer, middle),
                                            (layer, last)), (va, vb))
        return None

    def _spots(self, router, c: Connection, rule: NetRule, near: End | None = None) -> list:
        """Via spots that fit: rings around the ends (or `near` only) and points along the
        straight line, nearest the line's midpoint first (`near`: nearest that end)."""
        ends = [near] if near else [c.a, c.b]
        spots: set[Point] = set()
        for end in ends:
            unit = end.reach + rule.via_diameter / 2 + rule.clearance
            for step in RING_STEPS:
                ring = np.rint(np.array(end.at) + HEADINGS * unit * step).astype(np.int64)
                spots |= {(int(x), int(y)) for x, y in ring}
        if near is None:
            a, b = np.array(c.a.at, dtype=float), np.array(c.b.at, dtype=float)
            spots |= {(int(round(x)), int(round(y))) for x, y in
                      (a + t * (b - a) for t in (0.25, 0.5, 0.75))}
        ordered = sorted(spots)
        fits = router.vias_fit(c.net, ordered, rule.via_diameter, rule.clearance, self.layers)
        target = near.at if near else ((c.a.x + c.b.x) / 2, (c.a.y + c.b.y) / 2)
        chosen = [p for p, ok in zip(ordered, fits) if ok]
        return sorted(chosen, key=lambda p: ((p[0] - target[0]) ** 2 + (p[1] - target[1]) ** 2,
                                             p))


def _rank(plan: Plan) -> tuple:
    return (len(plan.open), math.fsum(w.length for w in plan.wires.values()))


def _too_close(a: CopperItem, core_a, radius_a: float, b: CopperItem) -> bool:
    if not set(a.layers) & set(b.layers):
        return False
    core_b, radius_b = copper_core(b)
    need = radius_a + radius_b + max(a.clearance, b.clearance) - TOLERANCE
    return bool(shapely.distance(core_a, core_b) < need)

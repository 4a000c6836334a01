"""Negotiated routing on plain geometry: every open connection of a board planned at once, with
rip-up and reroute, before any copper is laid.

Connections (`pcbdata.router.connections`): per net, a minimum spanning tree over its pad
clusters (Kruskal on the shortest pad-to-pad distance between two clusters), routed shortest
first. A connection is tried by the walkaround router (`pcbdata.router.walkaround`) on a layer
both ends are on, then by the layered search (`pcbdata.router.layered`: every layer at once,
vias as moves of the search, a via wherever one fits).

A connection that finds no way is searched again, by the layered search, on the board without
the other connections' planned copper that may still be ripped up, that copper being *soft*:
a way may cross it at a price (`rip_price` nm of track per crossed connection, once more for
each time that connection was ripped up before; `pcbdata.router.soft`). If no priced way is
found, a way that ignores the soft copper is taken. Either way its via spots keep off the
net's own planned vias (that board lacks them; a via over one would be two overlapping holes,
KiCad's hole_to_hole). The connections whose planned copper the way passes too close to are
ripped up (exact distances), the connection takes its way and the ripped ones are queued
again ahead of the rest; a connection is ripped at most `max_rips`
times (then it is hard copper, never crossed again), so the loop ends. A connection with no
way even on the board without planned copper is *boxed in*; one that has a way there but only
through copper that may not be ripped is *congested*; one that ran out of the budget is
*budget*. Where the first round leaves connections open, the repair below is tried on its
plan at once, with a smaller allowance taken from the rounds' budgets (`EARLY_REPAIR_WORK`,
`EARLY_REPAIR_ROUTES`): a plan it completes is the plan, without later rounds (on congested
boards they cost as much as the first, and seldom do better). Later rounds start again from a
clean board: the next two put the connections the best round left open first (an order
already tried is not run again: the round would repeat it); after those,
while the plan has budget left and an open connection that is not boxed in, each round takes
the connections hardest first, by their history (rip-ups and times left open, summed over
every round so far), and the rounds stop when that order repeats one already tried. The best
state seen (the best round, most connections routed, then least wire; or the first round's
repaired plan where it leaves no more open: a repair never leaves more open than its plan)
is then repaired where it leaves connections open that are not boxed in (`Negotiator._repair`,
with a budget of its own; where that state is the first round's plan that the repair went
through already within its allowance, the best later round is repaired instead and the better
of the two kept): each such connection is laid through the
other connections' copper, every connection it rips up is placed again (ripped at most once),
an attempt that rips up more than `REPAIR_RIPS` is given up (`CROWDED_RIPS` where the repair
starts with more than `CROWDED` open: its budget is shared by more attempts), each connection
an attempt leaves open is settled the same way before the attempt is judged (`REPAIR_DEPTH`
levels down; a settling is kept where it leaves nothing open), and the attempt is kept where it
leaves none of them open, or exactly one (the open connection changes, once per connection),
else undone; the layered searches of the repair weight their
heuristic (`REPAIR_WEIGHT`), a bounded suboptimal A* that finds long priced ways the rounds'
searches run out of budget on. Where that plan leaves a connection open that is not boxed in,
a second variant of the whole plan is made from a clean board with smaller budgets
(`VARIANT_WORK`, `VARIANT_REPAIR_WORK`): the same rounds and repairs, but a walkaround leg
longer than `DETOUR` times its ends' distance gives way to the layered search's way where that
costs less (on congested boards such legs wind round half the board and crowd the others out),
and the variant is kept where it leaves fewer open (boards differ in which of the two
completes them). That is the plan. Work is counted in route calls
(`budget_routes`), each search's expansions and link checks, and the link checks of all the
plan's searches together (`budget_work`), never timed: the same board gives the same plan on
any machine. The planner's routers prove where they can that a search has no way
(`WalkaroundRouter.prove_separation`: after `search.SEPARATION_AFTER` link checks, whether the
free space, joined through via spots for the layered search, keeps the ends apart): a search
so proven stops at once, so a plan that the budget does not end is the same with or without
the proofs, at less work, and one the budget ends goes further.

Every leg is a walkaround or layered path and every via fits where it stands, so the planned
copper keeps clearance by construction; KiCad judges it when it is laid
(`pcbdata.agents.negotiated` lays it through the environment's free-coordinate actions).
Nothing here imports KiCad.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np
import shapely

from pcbdata.router.clearance import TOLERANCE
from pcbdata.router.connections import Connection, End
from pcbdata.router.geometry import (
    BoardGeometry,
    CopperItem,
    Point,
    copper_core,
    octilinear_length,
)
from pcbdata.router.layered import VIA_COST, LayeredRequest
from pcbdata.router.requests import RouteRequest
from pcbdata.router.soft import SoftCopper
from pcbdata.router.walkaround import WalkaroundRouter

#: Route calls a plan may make (the budget), and rip-ups of one connection at most.
BUDGET_ROUTES = 3000
#: Link checks the searches of a plan may make in all (the routers' counted work, answers
#: remembered from earlier searches free); the plan stops where either budget runs out. The
#: completed D3-B and D3-C test picks need at most 5.2 million at seed 0, some real tier C
#: boards more than 40 million.
BUDGET_WORK = 80_000_000
MAX_RIPS = 3
#: What crossing a planned connection costs the rip-up search, in nm of track (once more for
#: every time that connection was ripped up before).
RIP_PRICE = 5_000_000
#: The second variant of a plan (`Negotiator.run`): a walkaround leg on a layer both ends are
#: on is taken where it is at most DETOUR times the octilinear distance between the ends (at
#: least DETOUR_FLOOR nm), a longer one only where the layered search finds no way as cheap
#: (its length and `via_cost` per via); its rounds may make VARIANT_WORK link checks, its
#: repairs VARIANT_REPAIR_WORK more.
DETOUR = 1.5
DETOUR_FLOOR = 2_000_000
VARIANT_WORK = 30_000_000
VARIANT_REPAIR_WORK = 10_000_000
#: Rounds after the first: the first OPEN_FIRST of them with the connections left open placed
#: first, the others hardest first by history (rip-ups, and OPEN_WEIGHT per round left open).
RESTARTS = 8
OPEN_FIRST = 2
OPEN_WEIGHT = 2
CAUSES = ("boxed_in", "congestion", "budget")
#: The plan's searches by kind, for its work tally (`Plan.stats["work_by_search"]`): a
#: walkaround leg on one layer, a layered search (every layer, vias as moves) and a rip-up
#: search (layered, crossing the soft copper at a price).
SEARCH_KINDS = ("walkaround", "layered", "rip-up")
#: Grid step (nm) of access points inside a pad whose centre a track cannot start at.
ACCESS_STEP = 50_000
#: The repair after the rounds (`Negotiator._repair`): the link checks and route calls it may
#: make beyond the rounds', the heuristic weight of its layered searches
#: (`LayeredRequest.heuristic_weight`), the search budget of its rip-up searches, in
#: multiples of the router's, how many levels down an attempt's fallout is settled before the
#: attempt is judged (`Negotiator._settle`), and the rip-ups after which an attempt is given up:
#: REPAIR_RIPS, or CROWDED_RIPS where the repair starts with more than CROWDED connections open
#: (the budget is shared by more attempts: a cascade of rip-ups given up sooner leaves more of
#: it to the others).
REPAIR_WORK = 40_000_000
REPAIR_ROUTES = 1000
REPAIR_WEIGHT = 2.0
REPAIR_SEARCH = 4
REPAIR_DEPTH = 1
REPAIR_RIPS = 24
CROWDED = 8
CROWDED_RIPS = 12
#: The repair tried on the first round's plan where that leaves connections open (taken from
#: the rounds' budgets): a plan it completes is the plan, without the later rounds.
EARLY_REPAIR_WORK = 10_000_000
EARLY_REPAIR_ROUTES = 1000


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
                 budget_routes: int = BUDGET_ROUTES, budget_work: int = BUDGET_WORK,
                 max_rips: int = MAX_RIPS,
                 restarts: int = RESTARTS, router_nodes: int | None = None,
                 router_checks: int | None = None, via_cost: int = VIA_COST,
                 rip_price: int = RIP_PRICE, prove_separation: bool = True,
                 repair_work: int = REPAIR_WORK, repair_depth: int = REPAIR_DEPTH,
                 repair_rips: int = REPAIR_RIPS, crowded: int = CROWDED,
                 crowded_rips: int = CROWDED_RIPS, detour: float = DETOUR,
                 variant_work: int = VARIANT_WORK):
        budgets = {k: v for k, v in (("budget_nodes", router_nodes),
                                     ("budget_checks", router_checks)) if v is not None}
        self.base, self.layers, self.rules = board, tuple(layers), rules
        self.budget, self.max_rips, self.restarts = budget_routes, max_rips, restarts
        self.budget_work = budget_work
        self.via_cost, self.rip_price = via_cost, rip_price
        self.repair_work, self.repair_depth = repair_work, repair_depth
        self.repair_rips, self.crowded, self.crowded_rips = repair_rips, crowded, crowded_rips
        self._rips_cap = repair_rips  # the cap of the repair under way (`_repair`)
        self.detour, self.variant_work = detour, variant_work
        self._detour_limit = math.inf  # the first plan's: a walkaround leg of any length
        self._weight = 1.0  # the layered searches' heuristic weight (more in the repair)
        # the board without planned copper; its searches stop where their ends are proven
        # apart (`WalkaroundRouter.prove_separation`: the same ways, less work)
        self.bare = WalkaroundRouter(board, prove_separation=prove_separation, **budgets)
        open_ends: dict[tuple[str, End], tuple[str, ...]] = {}  # ends shared by connections
        self.connections = [_accessible(self.bare, rules[c.net], c, open_ends)
                            for c in connections]
        self.router = self.bare.with_board(board)  # with all of it
        self.fixed_router = self.bare.with_board(board)  # with what may not be ripped up
        self.calls = 0
        # link checks by the kind of search and whether it found a way (`SEARCH_KINDS`)
        self.work_by_search = {f"{kind} {end}": 0 for kind in SEARCH_KINDS
                               for end in ("found", "none")}
        self._boxed_in: dict[int, bool] = {}
        self._reset()

    def _reset(self) -> None:
        self.wires: dict[int, Wire] = {}
        self.items: dict[int, list[CopperItem]] = {}
        self.rips = [0] * len(self.connections)
        self._stale = self._fixed_stale = True

    # --- the loop ---

    def run(self) -> Plan:
        """The plan (`_negotiate`); where it leaves a connection open that is not boxed in, a
        second variant of it is made on the same board (two layers or more), from a clean
        state, with the walkaround legs that are detours given up for a layered way where that
        costs less (`DETOUR`, `_way`) and smaller budgets (`variant_work` for its rounds, at
        most `VARIANT_REPAIR_WORK` for its repairs, as many route calls as the first), and
        kept where it leaves fewer open. Plans differ from board to board in which
        of the two completes; a plan the first completes is the same without the second."""
        budgets = (self.budget, self.budget_work, self.repair_work)  # the repairs move them
        plan = self._negotiate()
        if not self.variant_work or len(self.layers) < 2 or all(
                c == "boxed_in" for c in plan.open.values()):
            return plan
        self.budget, self.budget_work = self.calls + budgets[0], self.work + self.variant_work
        self.repair_work = min(VARIANT_REPAIR_WORK, budgets[2])
        self._detour_limit = self.detour
        try:
            other = self._negotiate()
        finally:
            self.budget, self.budget_work, self.repair_work = budgets
            self._detour_limit = math.inf
        taken = len(other.open) < len(plan.open)
        best = other if taken else plan
        best.stats = {**best.stats, "variant": int(taken), **self._totals()}
        return best

    def _negotiate(self) -> Plan:
        """Rounds of the negotiation, each from a clean board: the first in the connections'
        order; the next `OPEN_FIRST` with the connections the best round left open first
        (where that order was tried already, as it is when the best round and its open
        connections stay, the hardest-first order instead);
        then, while an open connection is not boxed in and the budget lasts, hardest first
        by history (`_by_history`) until an order repeats; the first round's plan repaired
        at once where it leaves connections open (`_early_repair`). The best state, repaired
        (see the module doc), is the plan."""
        order = list(range(len(self.connections)))
        history = [0] * len(self.connections)
        tried: set[tuple[int, ...]] = set()
        best_round: Plan | None = None
        round_one: Plan | None = None
        early: tuple[Plan, bool] | None = None  # the first round repaired; whether to the end
        rounds, rounds_open = 0, len(self.connections)
        while True:
            tried.add(tuple(order))
            plan = self._round(order)
            rounds += 1
            if rounds == 1:
                round_one = plan
            rounds_open = min(rounds_open, len(plan.open))
            for i in range(len(self.connections)):
                history[i] += self.rips[i] + (OPEN_WEIGHT if i in plan.open else 0)
            if best_round is None or _rank(plan) < _rank(best_round):
                best_round = plan
            if rounds == 1 and plan.open and self.repair_work > 0 and not self._spent():
                early = self._early_repair(plan)
            best = _better(best_round, early)
            if not best.open or self._spent() or rounds > self.restarts:
                break
            if rounds <= OPEN_FIRST:
                first = self._shortest_first(best_round.open)
                order = first + [i for i in order if i not in best_round.open]
                if tuple(order) not in tried:  # else the round would repeat one run already
                    continue
            if all(self._boxed(i) for i in best_round.open) or self._spent():
                break
            order = _by_history(history)
            if tuple(order) in tried:
                break
        if best.open and self.repair_work > 0:
            if early is None or best is not early[0] or not early[1]:
                best = self._repair(best)
            elif best_round is not round_one:  # the first round's repair is done: a later one's
                best = _better(self._repair(best_round), early)
        best.open = {i: self._cause(i, c) for i, c in sorted(best.open.items())}
        best.stats = {**best.stats, "rounds": rounds,
                      "repaired": max(0, rounds_open - len(best.open)),
                      "connections": len(self.connections), **self._totals()}
        return best

    def _totals(self) -> dict:
        """The plan's counted work so far: route calls, link checks, and those by search."""
        return {"route_calls": self.calls, "work": self.work,
                "work_by_search": dict(self.work_by_search)}

    def _shortest_first(self, indices) -> list[int]:
        """The connections `indices` shortest first, ties in the connections' order."""
        return sorted(indices, key=lambda i: (self.connections[i].length, i))

    # --- the repair ---

    def _early_repair(self, plan: Plan) -> tuple[Plan, bool]:
        """The first round's `plan` repaired (`_repair`) with at most `EARLY_REPAIR_WORK`
        link checks and `EARLY_REPAIR_ROUTES` route calls, taken from the rounds' budgets;
        and whether it finished within them (a plan repaired to the end: the last repair
        would only repeat it)."""
        budgets = self.budget, self.budget_work
        try:
            out = self._repair(plan, min(EARLY_REPAIR_WORK, self.repair_work,
                                         self.budget_work - self.work),
                               min(EARLY_REPAIR_ROUTES, self.budget - self.calls))
            return out, not self._spent()
        finally:
            self.budget, self.budget_work = budgets

    def _repair(self, plan: Plan, work: int | None = None,
                routes: int = REPAIR_ROUTES) -> Plan:
        """`plan` repaired, one open connection at a time (shortest first, boxed-in ones
        left), with `work` (default: the plan's `repair_work`) more link checks and `routes`
        more route calls than made so far: an attempt (`_attempt`) lays the connection through
        the other connections' copper and places the ones it rips up again (given up where
        more than `repair_rips` are ripped up, `crowded_rips` where `plan` leaves more than
        `crowded` open), and what it leaves open is settled the same
        way (`_settle`, `repair_depth` levels down). An attempt that then leaves none of them
        open is kept; one that leaves exactly one open is kept too (the open connection
        changes, their number does not), once per connection that moved so; any other is
        undone. Passes repeat while one keeps an attempt. So the repair never leaves more
        connections open than `plan`."""
        self.budget_work = self.work + (self.repair_work if work is None else work)
        self.budget = self.calls + routes
        fixed, max_rips = self.fixed_router, self.max_rips
        searches = fixed.budget_nodes, fixed.budget_checks
        fixed.budget_nodes, fixed.budget_checks = (n * REPAIR_SEARCH for n in searches)
        self.max_rips, self._weight = 1, REPAIR_WEIGHT
        self._rips_cap = self.crowded_rips if len(plan.open) > self.crowded else self.repair_rips
        wires, open_ = dict(plan.wires), dict(plan.open)
        moved: set[int] = set()
        try:
            kept = True
            while kept and not self._spent():
                kept = False
                for index in self._shortest_first(open_):
                    if self._spent():
                        break
                    if index not in open_ or self._boxed(index):
                        continue
                    attempt = self._settle(index, wires, self.repair_depth)
                    if attempt is None:
                        continue
                    after, still = attempt
                    if still and (len(still) > 1 or next(iter(still)) in moved):
                        continue
                    if still:
                        moved.add(index)
                    wires = after
                    del open_[index]
                    open_.update(still)
                    kept = True
        finally:
            fixed.budget_nodes, fixed.budget_checks = searches
            self.max_rips, self._weight = max_rips, 1.0
        return Plan(wires, open_, plan.stats)

    def _settle(self, index: int, wires: dict[int, Wire], depth: int
                ) -> tuple[dict[int, Wire], dict[int, str]] | None:
        """`_attempt` of connection `index` from `wires`; then each connection it left open
        that is not boxed in (shortest first) is settled the same way from the wires after,
        `depth - 1` levels down, and that settling is kept where it leaves nothing open: an
        attempt's fallout (a connection laid through the others often leaves one open that a
        second attempt lays) is repaired before the attempt is judged. The wires after and the
        connections still open, as `_attempt` gives them."""
        attempt = self._attempt(index, wires)
        if attempt is None or depth <= 0:
            return attempt
        after, still = attempt
        for other in self._shortest_first(still):
            if self._spent():
                break
            if self._boxed(other):
                continue
            settled = self._settle(other, after, depth - 1)
            if settled is not None and not settled[1]:
                after = settled[0]
                del still[other]
        return after, still

    def _attempt(self, index: int, wires: dict[int, Wire]
                 ) -> tuple[dict[int, Wire], dict[int, str]] | None:
        """From the planned `wires`: connection `index` laid by `_place` (its rip-up search
        may cross every other connection's copper), then each connection it ripped up placed
        again by `_place`, each ripped at most once (`max_rips` is 1 in the repair: ripped,
        a connection is hard copper once placed again). The wires after, and the connections
        left open with their causes; None where `index` found no way, or where the attempt
        has ripped up more than the repair's cap (`_repair`) connections (a cascade of rip-ups
        that seldom settles: its work is left to other attempts)."""
        self._load(wires)
        self.rips[index] = self.max_rips  # hard copper for the connections it rips up
        queue: deque = deque()
        if self._place(index, queue):
            return None
        failed: dict[int, str] = {}
        while queue and not self._spent():
            if sum(1 for k, r in enumerate(self.rips) if r and k != index) > self._rips_cap:
                return None
            other = queue.popleft()
            if other not in self.wires:
                cause = self._place(other, queue)
                if cause:
                    failed[other] = cause
        still = {i: failed.get(i, "budget") for i in sorted({*failed, *queue})
                 if i not in self.wires}
        return dict(self.wires), still

    def _load(self, wires: dict[int, Wire]) -> None:
        """The board's state with these wires planned, none ripped up yet."""
        self._reset()
        for index, wire in sorted(wires.items()):
            self._add(index, wire)

    @property
    def work(self) -> int:
        """Link checks made by the plan's searches so far."""
        return self.bare._shared.work

    def _spent(self) -> bool:
        """Whether the plan's budget is spent: its route calls or its searches' work."""
        return self.calls >= self.budget or self.work >= self.budget_work

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
            if not self._spent() and self._route_here(index):
                failed.pop(index)
                best = self._keep_best(best, failed)
        wires, open_ = (best[2], best[3]) if best else ({}, {})
        return Plan(dict(wires), dict(open_), {"rips": sum(self.rips)})

    def _cause(self, index: int, cause: str) -> str:
        """The cause of an open connection once the rounds are over: `budget` only where the
        plan's budget ran out (the best state may be one that a round had not yet tried
        every connection in and then went on from: such a connection is open for the
        others' copper); otherwise `boxed_in` where even the board without planned copper
        has no way for it (a repeated request costs nothing: the router remembers), else
        `congestion`."""
        if self._spent():
            return cause
        return "boxed_in" if self._boxed(index) else "congestion"

    def _boxed(self, index: int) -> bool:
        """Whether the board without planned copper has no way for connection `index`
        (asked once, by the rounds' search: that board never changes). Any way answers it,
        a walkaround leg however long (no detour limit)."""
        if index not in self._boxed_in:
            boxed = self._way(self.bare, index, weight=1.0, limit=math.inf) is None
            if self._spent():  # no answer, for want of budget
                return boxed
            self._boxed_in[index] = boxed
        return self._boxed_in[index]

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
        if self._spent():
            return "budget"
        if self._route_here(index):
            return ""
        wire = self._way(self._fixed(), index, self._soft(index))
        if wire is None:  # the way that crosses planned copper regardless of its price
            wire = self._way(self._fixed(), index)
        if wire is None:
            return "budget" if self._spent() else "congestion"
        blockers = self._blockers(index, wire)
        for b in blockers:
            self._drop(b)
            self.rips[b] += 1
            self._fixed_stale |= self.rips[b] >= self.max_rips
        self._add(index, wire)
        queue.extendleft(sorted(blockers, key=lambda b: (-self.rips[b], b), reverse=True))
        return ""

    def _detour(self, index: int, wire: Wire, limit: float) -> bool:
        """Whether `wire` is longer than `limit` times its connection's octilinear distance
        (at least DETOUR_FLOOR)."""
        c = self.connections[index]
        return wire.length > limit * max(octilinear_length(c.a.at, c.b.at), DETOUR_FLOOR)

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
        """Planned connections of other nets whose copper is too close to `wire`'s: an item of
        theirs on a layer of one of its items nearer than the two radii and the larger
        clearance allow (exact distances)."""
        net, rule = wire.net, self.rules[wire.net]
        others = [(other, items) for other, items in sorted(self.items.items())
                  if self.connections[other].net != net and self.rips[other] < self.max_rips]
        flat = [b for _, items in others for b in items]
        if not flat:
            return []
        bits = {layer: 1 << k for k, layer in enumerate(sorted({
            lay for b in flat for lay in b.layers} | set(self.layers)))}
        owner = np.repeat(np.arange(len(others)), [len(items) for _, items in others])
        shapes = [self.bare.prepared(b) for b in flat]
        cores = np.array([p.core for p in shapes], dtype=object)
        radius = np.array([p.radius for p in shapes])
        clearance = np.array([b.clearance for b in flat])
        layers = np.array([sum(bits[lay] for lay in b.layers) for b in flat])
        close = np.zeros(len(flat), dtype=bool)
        for a in wire.items(rule, self.layers):
            mine = self.bare.prepared(a)
            todo = np.flatnonzero(~close & ((layers & sum(bits[lay] for lay in a.layers)) != 0))
            need = mine.radius + radius[todo] + np.maximum(a.clearance, clearance[todo])
            close[todo] = shapely.distance(mine.core, cores[todo]) < need - TOLERANCE
        return [others[k][0] for k in np.unique(owner[close])]

    # --- ways ---

    def _soft(self, index: int) -> SoftCopper:
        """The planned copper of other nets that may still be ripped up, each connection at
        its price: `rip_price` nm of track, once more for every time it was ripped."""
        net = self.connections[index].net
        owners = [k for k in sorted(self.items) if self.rips[k] < self.max_rips
                  and self.connections[k].net != net]
        items = tuple(i for k in owners for i in self.items[k])
        return SoftCopper(items, tuple(k for k in owners for _ in self.items[k]),
                          {k: self.rip_price * (1 + self.rips[k]) for k in owners})

    def _way(self, router: WalkaroundRouter, index: int,
             soft: SoftCopper | None = None, weight: float | None = None,
             limit: float | None = None) -> Wire | None:
        """A way for connection `index`: a walkaround path on a layer both ends are on, else
        the layered search (every layer, vias as moves of the search,
        `pcbdata.router.layered`); a walkaround path longer than `limit` (else the plan's
        `_detour_limit`: none in the first variant) times its ends' distance (`_detour`) is
        kept only where the layered search finds no way or none cheaper (its length and
        `via_cost` per via). With `soft`, only the layered search, which may cross that copper
        at its price. The layered search's heuristic weight is `weight`, else the plan's
        (`_weight`: more in the repair)."""
        c = self.connections[index]
        rule = self.rules[c.net]
        leg: Wire | None = None
        if soft is None:
            for layer in [lay for lay in self.layers
                          if lay in c.a.layers and lay in c.b.layers]:
                path = self._leg(router, c.net, layer, c.a.at, c.b.at, rule)
                if path:
                    leg = Wire(c.net, ((layer, path),))
                    break
            if leg is not None and (len(self.layers) < 2 or not self._detour(
                    index, leg, self._detour_limit if limit is None else limit)):
                return leg
            if len(self.layers) < 2:
                return None
        if self._spent():
            return leg
        self.calls += 1
        holes = self._own_holes(index) if router is self.fixed_router else ()
        before = self.work
        result = router.route_layers(LayeredRequest(
            net=c.net, start=c.a.at, start_layers=c.a.layers, goal=c.b.at,
            goal_layers=c.b.layers, width=rule.width, clearance=rule.clearance,
            via_diameter=rule.via_diameter, layers=self.layers, reach=(c.a.reach, c.b.reach),
            via_cost=self.via_cost, holes=holes,
            heuristic_weight=self._weight if weight is None else weight), soft)
        self._tally("rip-up" if soft is not None else "layered", before, result.legs)
        if result.legs is None:
            return leg
        wire = Wire(c.net, result.legs, result.vias)
        if leg is not None and leg.length <= wire.length + self.via_cost * len(wire.vias):
            return leg
        return wire

    def _own_holes(self, index: int) -> tuple[tuple[Point, int], ...]:
        """The planned vias of the connection's net (the rip-up search's board has only those
        that may not be ripped up): its via spots keep off them."""
        net = self.connections[index].net
        diameter = self.rules[net].via_diameter
        return tuple(sorted({(v, diameter) for wire in self.wires.values()
                             if wire.net == net for v in wire.vias}))

    def _leg(self, router, net, layer, a: Point, b: Point, rule: NetRule):
        if a == b:
            return (a,)
        if self._spent():
            return None
        self.calls += 1
        before = self.work
        result = router.route(RouteRequest(net=net, layer=layer, start=a, goal=b,
                                           width=rule.width, clearance=rule.clearance))
        self._tally("walkaround", before, result.path)
        return None if result.path is None else tuple((int(x), int(y)) for x, y in result.path)

    def _tally(self, kind: str, before: int, way) -> None:
        """Adds the link checks made since `before` to `work_by_search`."""
        self.work_by_search[f"{kind} {'none' if way is None else 'found'}"] += (
            self.work - before)


def _accessible(router: WalkaroundRouter, rule: NetRule, c: Connection,
                open_ends: dict[tuple[str, End], tuple[str, ...]] | None = None) -> Connection:
    """`c`, or where a track cannot start at an end's pad centre on any of its layers (a pad
    whose centre lies off the board or too near other copper) and can at the other end, `c`
    from the other end to an access point: the point of that pad's copper nearest its centre
    where a track can end (the agent starts a wire at a pad centre, and may end it anywhere).
    `open_ends` remembers each end's open layers (one net, one rule), across connections."""
    open_ends = {} if open_ends is None else open_ends
    for end in (c.a, c.b):
        if (c.net, end) not in open_ends:
            open_ends[c.net, end] = _open_layers(router, rule, c.net, end)
    a_ok, b_ok = open_ends[c.net, c.a], open_ends[c.net, c.b]
    if a_ok and b_ok or not (a_ok or b_ok):
        return c
    good, bad = (c.a, c.b) if a_ok else (c.b, c.a)
    point = _access_point(router, rule, c.net, bad)
    if point is None:
        return c
    return Connection(c.net, good, End(point[0], point[1], point[2], 0))


def _open_layers(router, rule: NetRule, net: str, end: End) -> tuple[str, ...]:
    return tuple(lay for lay in end.layers if not router._point_problem(
        router._rules(net, lay, rule.width, rule.clearance), end.at))


def _access_point(router, rule: NetRule, net: str, end: End):
    """(x, y, layers) of the nearest point to `end` inside its pad's copper (a grid of
    ACCESS_STEP) where a track of the net's width can end, or None."""
    pads = [item for item in router.board.copper if item.kind == "pad" and item.net == net
            and set(end.layers) & set(item.layers)
            and shapely.contains_xy(copper_core(item)[0], *end.at)]
    if not pads:
        return None
    shape = copper_core(pads[0])[0]
    span = np.arange(-end.reach, end.reach + 1, ACCESS_STEP)
    grid = np.array([(end.x + dx, end.y + dy) for dx in span for dy in span], dtype=np.int64)
    grid = grid[shapely.contains_xy(shape, grid[:, 0], grid[:, 1])]
    grid = grid[np.lexsort((grid[:, 1], grid[:, 0], np.hypot(*(grid - end.at).T)))]
    dots = np.repeat(grid[:, None, :].astype(float), 2, axis=1)
    inside = router._inside(grid.astype(float))
    fits = {lay: inside & ~router._rules(net, lay, rule.width, rule.clearance).failing(dots)
            for lay in end.layers}
    for k in np.flatnonzero(np.any(list(fits.values()), axis=0)):
        return int(grid[k, 0]), int(grid[k, 1]), tuple(lay for lay in end.layers
                                                       if fits[lay][k])
    return None


def _by_history(history: list[int]) -> list[int]:
    """The connections hardest first: most history first, ties in the connections' order."""
    return sorted(range(len(history)), key=lambda i: (-history[i], i))


def _better(plan: Plan, repaired: tuple[Plan, bool] | None) -> Plan:
    """`plan`, or the repaired plan (`_early_repair`'s) where that leaves no more open."""
    if repaired is not None and len(repaired[0].open) <= len(plan.open):
        return repaired[0]
    return plan


def _rank(plan: Plan) -> tuple:
    return (len(plan.open), math.fsum(w.length for w in plan.wires.values()))


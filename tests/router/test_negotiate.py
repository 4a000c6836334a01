"""The negotiated planner on hand-made plain geometry: spanning trees, rip-up and reroute, the
plan's legality (checked against exact shapes, independently of the router), counted work."""
from __future__ import annotations

import itertools

import shapely

from pcbdata.router.connections import Connection, End, spanning_connections
from pcbdata.router.geometry import BoardGeometry, CopperItem, copper_core
from pcbdata.router.negotiate import (
    BUDGET_WORK,
    DETOUR,
    REPAIR_WORK,
    SEARCH_KINDS,
    VARIANT_REPAIR_WORK,
    VARIANT_WORK,
    Negotiator,
    NetRule,
    Plan,
    Wire,
)

MM = 1_000_000
LAYERS = ("F.Cu",)


def mm(x: float) -> int:
    return round(x * MM)


def square(x: float, y: float, half: float) -> tuple:
    return ((mm(x - half), mm(y - half)), (mm(x + half), mm(y - half)),
            (mm(x + half), mm(y + half)), (mm(x - half), mm(y + half)))


def pad(net: str, x: float, y: float) -> CopperItem:
    return CopperItem(kind="pad", net=net, layers=LAYERS, polygon=square(x, y, 0.15),
                      clearance=mm(0.2))


def wall(y0: float, y1: float) -> CopperItem:
    """No-net copper across x 14.5-15.5 from y0 to y1."""
    return CopperItem(kind="zone", net="WALL", layers=LAYERS, clearance=mm(0.2), polygon=(
        (mm(14.5), mm(y0)), (mm(15.5), mm(y0)), (mm(15.5), mm(y1)), (mm(14.5), mm(y1))))


def gates_board() -> tuple[BoardGeometry, list[Connection], dict[str, NetRule]]:
    """A wall splits the board; gate 1 (0.95 mm) passes one wide track, gate 2 (0.7 mm) only a
    narrow one. A (narrow, shorter) and B (wide) both cross: A first takes gate 1, so B can
    only be routed by ripping A up and sending A through gate 2."""
    outline = ((((0, 0), (mm(30), 0), (mm(30), mm(30)), (0, mm(30)))),)
    copper = (wall(0, 14.525), wall(15.475, 26.65), wall(27.35, 30),
              pad("A", 12, 13), pad("A", 18, 17), pad("B", 5, 15), pad("B", 25, 15))
    board = BoardGeometry(outline=outline, copper=copper, edge_clearance=mm(0.2))
    ends = {name: End(mm(x), mm(y), LAYERS, mm(0.15)) for name, x, y in
            (("a1", 12, 13), ("a2", 18, 17), ("b1", 5, 15), ("b2", 25, 15))}
    connections = spanning_connections([("A", ends["a1"], 0), ("A", ends["a2"], 1),
                                        ("B", ends["b1"], 2), ("B", ends["b2"], 3)])
    rules = {"A": NetRule(mm(0.2), mm(0.2), mm(0.6), mm(0.3)),
             "B": NetRule(mm(0.5), mm(0.2), mm(0.6), mm(0.3))}
    return board, connections, rules


def assert_legal(board: BoardGeometry, items: list[CopperItem]) -> None:
    """Every planned item keeps its clearance to every other net's copper (exact shapes) and
    lies inside the outline by the edge clearance."""
    region = shapely.Polygon(board.outline[0])
    everything = list(board.copper) + items
    for a in items:
        core_a, ra = copper_core(a)
        inset = region.buffer(-(ra + board.edge_clearance) + 1)
        assert inset.covers(core_a), f"{a} too close to the edge"
        for b in everything:
            if b.net == a.net or not set(a.layers) & set(b.layers):
                continue
            core_b, rb = copper_core(b)
            gap = shapely.distance(core_a, core_b) - ra - rb
            assert gap >= max(a.clearance, b.clearance) - 1, (a, b, gap)


def test_spanning_connections_join_clusters_shortest_first():
    e = [End(mm(x), 0, LAYERS) for x in (0, 1, 3, 10)]
    conns = spanning_connections([("N", e[0], 0), ("N", e[1], 0), ("N", e[2], 1),
                                  ("N", e[3], 2), ("M", e[0], 5)])
    # clusters {0,1}, {3}, {10}: two edges, 1-3 (2 mm) then 3-10 (7 mm); M has one pad
    assert [(c.net, c.a.x, c.b.x) for c in conns] == [("N", mm(1), mm(3)), ("N", mm(3), mm(10))]


def test_a_rip_up_frees_the_last_connection():
    board, connections, rules = gates_board()
    assert [c.net for c in connections] == ["A", "B"]  # A is the shorter: routed first
    without = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0,
                         repair_work=0).run()
    assert sorted(without.wires) == [0] and without.open == {1: "congestion"}
    plan = Negotiator(board, LAYERS, rules, connections, restarts=0).run()
    assert sorted(plan.wires) == [0, 1] and plan.open == {}
    assert plan.stats["rips"] == 1 and plan.stats["rounds"] == 1
    assert plan.stats["repaired"] == 0  # complete before the repair: it never ran
    # without rip-ups, a second round that places the open connection first also gets there
    history = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=1,
                         repair_work=0).run()
    assert history.open == {} and history.stats["rounds"] == 2
    a_path = plan.wires[0].legs[0][1]
    assert max(y for _, y in a_path) > mm(26)  # A went round through gate 2
    items = [i for w in plan.wires.values() for i in w.items(rules[w.net], LAYERS)]
    assert_legal(board, items)


def test_plans_are_deterministic_and_the_budget_counts_route_calls():
    board, connections, rules = gates_board()
    one = Negotiator(board, LAYERS, rules, connections).run()
    two = Negotiator(board, LAYERS, rules, connections).run()
    assert one.wires == two.wires and one.stats == two.stats
    short = Negotiator(board, LAYERS, rules, connections, budget_routes=1,
                       repair_work=0).run()
    assert short.stats["route_calls"] == 1
    assert set(short.open.values()) <= {"budget"} and len(short.wires) == 1


def test_the_plans_work_is_split_by_the_kind_of_search_that_made_it():
    board, connections, rules = gates_board()
    plan = Negotiator(board, LAYERS, rules, connections, restarts=0).run()
    split = plan.stats["work_by_search"]
    assert sorted(split) == sorted(f"{kind} {end}" for kind in SEARCH_KINDS
                                   for end in ("found", "none"))
    assert sum(split.values()) == plan.stats["work"] > 0
    # B finds no walkaround past A's copper, then a rip-up search lays it through A's
    assert plan.stats["rips"] == 1
    assert split["walkaround none"] > 0 and split["rip-up found"] > 0
    assert split["rip-up none"] == 0


def test_the_work_budget_counts_link_checks_and_stops_the_plan():
    board, connections, rules = gates_board()
    full = Negotiator(board, LAYERS, rules, connections, restarts=0).run()
    assert full.open == {} and full.stats["work"] > 0
    # A routes straight (no search, no checks); B's first search spends the budget of one
    # check, so the plan stops there with B open for want of budget
    short = Negotiator(board, LAYERS, rules, connections, restarts=0, budget_work=1,
                       repair_work=0).run()
    assert short.open == {1: "budget"} and sorted(short.wires) == [0]
    assert 1 <= short.stats["work"] < full.stats["work"]
    assert short.stats["route_calls"] < full.stats["route_calls"]
    again = Negotiator(board, LAYERS, rules, connections, restarts=0, budget_work=1,
                       repair_work=0).run()
    assert again.wires == short.wires and again.stats == short.stats
    # the repair's work is its own: after the rounds' budget is spent, it still places B
    repaired = Negotiator(board, LAYERS, rules, connections, restarts=0, budget_work=1).run()
    assert repaired.open == {} and repaired.stats["repaired"] == 1
    assert repaired.stats["work"] > short.stats["work"]


class _Scripted(Negotiator):
    """The negotiation's rounds with each round's outcome given (rip-ups and open
    connections per round), to follow the orders of the later rounds (no repair after them:
    its wires are not real)."""

    def __init__(self, script, *args, **kwargs):
        super().__init__(*args, **{"repair_work": 0, **kwargs})
        self.script, self.orders = list(script), []

    def _round(self, order):
        self._reset()
        self.orders.append(list(order))
        rips, open_ = self.script.pop(0)
        self.rips = list(rips)
        wires = {i: Wire("A", (("F.Cu", ((0, 0), (i + 1, 0))),)) for i in range(3)
                 if i not in open_}
        return Plan(wires, {i: "congestion" for i in open_}, {"rips": sum(rips)})


def test_later_rounds_go_hardest_first_by_history_until_an_order_repeats():
    board, connections, rules = gates_board()
    three = connections + [connections[0]]  # the third has a way on the bare board
    script = [([0, 3, 0], {2}),  # history: 0, 3, 2
              ([0, 0, 0], {2}),  # open first: 2, 0, 1; history 0, 3, 4
              ([0, 0, 0], set())]  # hardest first: 2, 1, 0
    done = _Scripted(list(script), board, LAYERS, rules, three)
    plan = done.run()
    # the second open-first round would repeat the first (the same best round, the same
    # open connections first): it is not run, and the hardest-first round follows
    assert done.orders == [[0, 1, 2], [2, 0, 1], [2, 1, 0]]
    assert plan.open == {} and plan.stats["rounds"] == 3
    # a history round that leaves the same connection open only adds to its history: the
    # hardest-first order repeats, and the rounds stop
    stuck = _Scripted(script[:2] + [([0, 0, 0], {2})] * 5, board, LAYERS, rules, three)
    plan = stuck.run()
    assert stuck.orders[2:] == [[2, 1, 0]] and plan.open == {2: "congestion"}
    # a second open-first round runs where the best round changed its order: here the
    # second round is the best and leaves 0 open, and the third puts 0 first
    better = [([0, 3, 0], {1, 2}), ([0, 0, 0], {0}), ([0, 0, 0], set())]
    moved = _Scripted(better, board, LAYERS, rules, three)
    assert moved.run().open == {} and moved.orders == [[0, 1, 2], [2, 1, 0], [0, 2, 1]]
    # only one open-first round when restarts allow no more
    short = _Scripted(list(script), board, LAYERS, rules, three, restarts=1)
    assert short.run().stats["rounds"] == 2 and short.orders[-1] == [2, 0, 1]


def test_boxed_in_end_is_named():
    board, _, rules = gates_board()
    walls = tuple(CopperItem(kind="zone", net="WALL", layers=LAYERS, clearance=mm(0.2),
                             polygon=square(*xy, 0.4))
                  for xy in itertools.product((4.0, 6.0), (14.0, 16.0)))
    ring = tuple(CopperItem(kind="zone", net="WALL", layers=LAYERS, clearance=mm(0.2),
                            polygon=square(x, y, 0.4))
                 for x, y in ((5.0, 14.0), (5.0, 16.0), (4.0, 15.0), (6.0, 15.0)))
    boxed = BoardGeometry(board.outline, board.copper + walls + ring, board.edge_clearance)
    b = [End(mm(5), mm(15), LAYERS, mm(0.15)), End(mm(25), mm(15), LAYERS, mm(0.15))]
    plan = Negotiator(boxed, LAYERS, rules, [Connection("B", *b)]).run()
    assert plan.open == {0: "boxed_in"}
    # no later round: the open connection first is the first round's order again, and no
    # order frees a boxed-in end
    assert plan.stats["rounds"] == 1
    # with others beside it: after the open-first round, the hardest-first order (1, 2, 0)
    # would be new, but every open connection is boxed in, so no round by history runs
    a = gates_board()[1][0]  # A's connection, with a way on this board
    script = [([0, 0, 3], {1})] + [([0, 0, 0], {1})] * 4
    rounds = _Scripted(script, boxed, LAYERS, rules, [a, Connection("B", *b), a])
    assert rounds.run().open == {1: "boxed_in"}
    assert rounds.orders == [[0, 1, 2], [1, 0, 2]]


def test_seeded_orders_differ_and_repeat():
    from pcbdata.router.connections import seeded_order

    ends = [End(mm(x), mm(y), LAYERS) for x, y in ((0, 0), (1, 0), (0, 5), (2, 5), (9, 9),
                                                  (9, 10.5), (4, 4), (6, 4.5))]
    conns = [Connection(f"N{i}", ends[2 * i], ends[2 * i + 1]) for i in range(4)]
    assert seeded_order(conns, 0) == conns
    orders = {tuple(c.net for c in seeded_order(conns, s)) for s in range(1, 30)}
    assert len(orders) > 1
    assert seeded_order(conns, 7) == seeded_order(list(reversed(conns)), 7)


def test_budget_is_the_cause_only_where_the_budget_ran_out():
    """A connection the best state had not tried yet is open for want of budget only if the
    plan's budget is spent; otherwise the others' copper (or its own pins) kept it open."""
    board, connections, rules = gates_board()
    plan = Negotiator(board, LAYERS, rules, connections, restarts=0)
    assert plan._cause(1, "budget") == "congestion"  # B has a way on the bare board
    spent = Negotiator(board, LAYERS, rules, connections, restarts=0, budget_routes=0)
    assert spent._cause(1, "budget") == "budget"


def test_a_repair_attempt_that_rips_up_more_than_its_cap_is_given_up():
    """B's attempt rips A up: with at most 0 rip-ups an attempt is given up and B stays
    open; with 1 it is laid."""
    board, connections, rules = gates_board()
    capped = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0,
                        repair_rips=0).run()
    assert capped.open == {1: "congestion"} and capped.stats["repaired"] == 0
    one = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0,
                     repair_rips=1).run()
    assert one.open == {} and one.stats["repaired"] == 1


def test_a_repair_that_starts_crowded_gives_attempts_up_at_the_crowded_cap():
    """The cap on an attempt's rip-ups is `crowded_rips` where the repair starts with more
    than `crowded` connections open, `repair_rips` otherwise: B's attempt rips A up, so with a
    crowded cap of 0 it is given up only where the one open connection counts as crowded."""
    board, connections, rules = gates_board()

    def plan(crowded):
        return Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0,
                          repair_rips=1, crowded=crowded, crowded_rips=0).run()

    assert plan(crowded=1).open == {}  # one open, not more than 1: the cap of 1
    crowded = plan(crowded=0)
    assert crowded.open == {1: "congestion"} and crowded.stats["repaired"] == 0


def test_the_repair_lays_an_open_connection_through_planned_copper_and_places_it_again():
    """Rounds that may not rip up (max_rips 0, one round) leave B open behind A; the repair
    lays B through gate 1, rips A up and sends A through gate 2, as a rip-up in the rounds
    would."""
    board, connections, rules = gates_board()
    plan = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0).run()
    assert sorted(plan.wires) == [0, 1] and plan.open == {}
    assert plan.stats["repaired"] == 1 and plan.stats["rounds"] == 1
    assert max(y for _, y in plan.wires[0].legs[0][1]) > mm(26)  # A through gate 2
    items = [i for w in plan.wires.values() for i in w.items(rules[w.net], LAYERS)]
    assert_legal(board, items)
    again = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0).run()
    assert again.wires == plan.wires and again.stats == plan.stats


def test_the_first_rounds_plan_is_repaired_before_any_later_round():
    """Rounds that may not rip up leave B open after the first; a second round (B first)
    would complete the plan, but the repair tried on the first round's plan completes it
    already: no later round runs, and the repair is not run again at the end."""
    board, connections, rules = gates_board()
    plan = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=1).run()
    assert plan.open == {} and plan.stats["rounds"] == 1 and plan.stats["repaired"] == 1
    assert max(y for _, y in plan.wires[0].legs[0][1]) > mm(26)  # A through gate 2
    once = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0).run()
    assert once.wires == plan.wires and once.stats["work"] == plan.stats["work"]
    # without a repair, the second round completes it
    rounds = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=1,
                        repair_work=0).run()
    assert rounds.open == {} and rounds.stats["rounds"] == 2


def test_the_early_repair_is_taken_from_the_rounds_budget():
    """The first round's repair may spend no more than what the rounds' work budget leaves:
    with the rounds' budget spent by the first round it is not tried; with one link check
    left it runs short, and the repair at the end (a budget of its own) places B."""
    board, connections, rules = gates_board()
    first = Negotiator(board, LAYERS, rules, connections, max_rips=0, restarts=0,
                       repair_work=0).run()
    spent = first.stats["work"]
    early: list[int] = []

    class _Watched(Negotiator):
        def _early_repair(self, plan):
            out = super()._early_repair(plan)
            early.append(len(out[0].open))
            return out

    plan = _Watched(board, LAYERS, rules, connections, max_rips=0, restarts=1,
                    budget_work=spent).run()
    assert early == [] and plan.open == {} and plan.stats["rounds"] == 1
    plan = _Watched(board, LAYERS, rules, connections, max_rips=0, restarts=1,
                    budget_work=spent + 1).run()
    assert early == [1] and plan.open == {} and plan.stats["rounds"] == 1
    assert plan.stats["repaired"] == 1


class _ScriptedRepair(_Scripted):
    """`_Scripted` rounds and a repair whose outcome is given per call: the connections it
    leaves open; the plans it was asked to repair are kept."""

    def __init__(self, script, repairs, *args, **kwargs):
        super().__init__(script, *args, **{"repair_work": 1000, **kwargs})
        self.repairs, self.repaired_from = list(repairs), []

    def _repair(self, plan, work=None, routes=0):
        self.repaired_from.append(sorted(plan.open))
        open_ = self.repairs.pop(0)
        wires = {i: Wire("A", (("F.Cu", ((0, 0), (i + 1, 0))),)) for i in range(3)
                 if i not in open_}
        return Plan(wires, {i: "congestion" for i in open_}, plan.stats)


def test_the_later_rounds_follow_the_rounds_and_the_last_repair_takes_the_best_later_round():
    """The first round leaves 0, 1, 2 open and its repair (to the end) leaves 1: that is the
    best state, but the later rounds still put the first round's open connections first, and
    at the end, that repair being done, the best later round ({0, 2} open) is repaired
    instead, which completes it."""
    board, connections, rules = gates_board()
    three = connections + [connections[0]]
    script = [([0, 0, 0], {0, 1, 2}), ([0, 0, 0], {0, 2}), ([0, 0, 0], {0, 2}),
              ([0, 0, 0], {0, 2})]
    flow = _ScriptedRepair(script, [{1}, set()], board, LAYERS, rules, three, restarts=2)
    plan = flow.run()
    # not the repaired plan's {1} first; then no round repeats that order, and the
    # hardest-first order is that order too: the rounds stop
    assert flow.orders[1:] == [[0, 2, 1]]
    assert flow.repaired_from == [[0, 1, 2], [0, 2]] and plan.open == {}
    # where the best later round's repair does worse, the first round's repaired plan stays
    flow = _ScriptedRepair(script, [{1}, {0, 2}], board, LAYERS, rules, three, restarts=2)
    plan = flow.run()
    assert flow.repaired_from == [[0, 1, 2], [0, 2]] and sorted(plan.open) == [1]


def test_a_repair_may_change_which_connection_is_open_once_never_their_number():
    """Gate 2 closed: one crossing for two nets. The rounds route A (the shorter) and leave B
    open; the repair lays B through A's copper and A finds no way back: one open either way,
    so the attempt is kept (B moved) and A is open. A's own attempt would leave B open
    again, and B has moved once: undone. The plan never swings back and forth."""
    board, connections, rules = gates_board()
    closed = BoardGeometry(board.outline, board.copper + (wall(26.6, 27.4),),
                           board.edge_clearance)
    rounds = Negotiator(closed, LAYERS, rules, connections, restarts=0, repair_work=0).run()
    assert sorted(rounds.wires) == [0] and rounds.open == {1: "congestion"}
    plan = Negotiator(closed, LAYERS, rules, connections, restarts=0).run()
    assert sorted(plan.wires) == [1] and plan.open == {0: "congestion"}
    assert plan.stats["repaired"] == 0 and plan.stats["work"] > rounds.stats["work"]
    items = [i for w in plan.wires.values() for i in w.items(rules[w.net], LAYERS)]
    assert_legal(closed, items)


class _Attempts(Negotiator):
    """The repair with each attempt's outcome given: per connection, in turn, the connections
    the attempt rips up and leaves open (None: no way). Records every attempt and the wires it
    started from."""

    def __init__(self, script, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.script, self.tried = {k: list(v) for k, v in script.items()}, []

    def _boxed(self, index):
        return False

    def _attempt(self, index, wires):
        self.tried.append((index, tuple(sorted(wires))))
        outcome = self.script[index].pop(0)
        if outcome is None:
            return None
        still = {i: "congestion" for i in outcome}
        after = {k: w for k, w in wires.items() if k not in still}
        return {**after, index: _wire(index)}, still


def _wire(index: int) -> Wire:
    return Wire("A", (("F.Cu", ((0, 0), (index + 1, 0))),))


def _attempts(script, open_, depth):
    board, connections, rules = gates_board()
    four = [connections[0]] * 4
    wires = {i: _wire(i) for i in range(4) if i not in open_}
    negotiator = _Attempts(script, board, LAYERS, rules, four, repair_depth=depth)
    plan = negotiator._repair(Plan(dict(wires), {i: "congestion" for i in open_}))
    return plan, negotiator.tried


def test_the_repair_settles_an_attempts_fallout_before_judging_it():
    """Connection 0's attempt rips 1 and 2 up and cannot place them again: two open for one,
    undone without settling. Settled one level down (1, then 2, each from the wires after the
    attempt before), both are laid again and the attempt is kept."""
    script = {0: [(1, 2)], 1: [()], 2: [()]}
    plan, tried = _attempts(script, {0}, depth=1)
    assert plan.open == {} and sorted(plan.wires) == [0, 1, 2, 3]
    assert tried == [(0, (1, 2, 3)), (1, (0, 3)), (2, (0, 1, 3))]
    plan, tried = _attempts({0: [(1, 2)]}, {0}, depth=0)
    assert plan.open == {0: "congestion"} and tried == [(0, (1, 2, 3))]


def test_a_settling_is_kept_only_where_it_leaves_nothing_open():
    """Settling 1 leaves 3 open (not kept), settling 2 leaves none (kept): the attempt leaves
    1 open for 0, a change of the open connection, kept once; the next pass's attempt on 1
    finds no way, and the plan keeps one open."""
    script = {0: [(1, 2)], 1: [(3,), None], 2: [()]}
    plan, tried = _attempts(script, {0}, depth=1)
    assert plan.open == {1: "congestion"} and sorted(plan.wires) == [0, 2, 3]
    assert [i for i, _ in tried] == [0, 1, 2, 1]


def test_a_ways_blockers_are_the_other_nets_planned_copper_too_close_on_its_layers():
    """`_blockers`: the planned connections of other nets with an item on a layer of the way's
    nearer than the clearance allows (a track across it on its layer, a via on both layers);
    not one on the other layer only, one far enough, one of the way's own net, nor one ripped
    up `max_rips` times (hard copper). The same as a pair-by-pair check of exact shapes."""
    two = ("F.Cu", "B.Cu")
    outline = ((((0, 0), (mm(30), 0), (mm(30), mm(30)), (0, mm(30)))),)
    board = BoardGeometry(outline=outline, copper=(), edge_clearance=mm(0.2))
    end = End(mm(1), mm(1), two, 0)
    nets = ("A", "B", "C", "D", "E", "F", "G")
    rules = {n: NetRule(mm(0.2), mm(0.2), mm(0.6), mm(0.3)) for n in nets}
    negotiator = Negotiator(board, two, rules, [Connection(n, end, end) for n in nets])

    def track(net, layer, a, b):
        return Wire(net, ((layer, ((mm(a[0]), mm(a[1])), (mm(b[0]), mm(b[1])))),))

    planned = {
        0: track("A", "F.Cu", (10, 10), (20, 10)),  # across the way on its layer
        1: track("B", "B.Cu", (10, 10), (20, 10)),  # across it on the other layer only
        2: track("C", "F.Cu", (10, 12), (20, 12)),  # 1 mm past its end: clear
        3: Wire("D", (("F.Cu", ((mm(15.5), mm(9.5)), (mm(15.5), mm(9.6)))),
                      ("B.Cu", ((mm(15.5), mm(9.6)), (mm(16), mm(9.6))))),
                ((mm(15.5), mm(9.6)),)),  # its via beside the way, on both layers
        4: track("E", "F.Cu", (14, 9), (16, 9)),  # the way's own net
        5: track("F", "F.Cu", (10, 9.5), (20, 9.5)),  # across it, but hard copper
    }
    for index, wire in planned.items():
        negotiator._add(index, wire)
    negotiator.rips[5] = negotiator.max_rips
    way = track("E", "F.Cu", (15, 8), (15, 11))
    found = negotiator._blockers(6, way)
    assert found == [0, 3]
    mine = way.items(rules["E"], two)
    expect = sorted(k for k, items in negotiator.items.items()
                    if planned[k].net != "E" and negotiator.rips[k] < negotiator.max_rips
                    and any(set(a.layers) & set(b.layers) and shapely.distance(
                        copper_core(a)[0], copper_core(b)[0]) - copper_core(a)[1]
                        - copper_core(b)[1] < max(a.clearance, b.clearance)
                        for a in mine for b in items))
    assert found == expect


def _detour_board() -> tuple[BoardGeometry, list[Connection], dict[str, NetRule]]:
    """Two layers; net A's pads, on F.Cu only, 20 mm apart across a wall on F.Cu only that
    leaves a passage 1 mm wide at the far edge: on F.Cu alone the way round is about 64 mm,
    through B.Cu (two vias) 20 mm."""
    outline = ((((0, 0), (mm(30), 0), (mm(30), mm(30)), (0, mm(30)))),)
    top = ("F.Cu",)
    wall_ = CopperItem(kind="zone", net="WALL", layers=top, clearance=mm(0.2), polygon=(
        (mm(14.5), 0), (mm(15.5), 0), (mm(15.5), mm(29)), (mm(14.5), mm(29))))
    pads = tuple(CopperItem(kind="pad", net="A", layers=top, polygon=square(x, 2, 0.15),
                            clearance=mm(0.2)) for x in (5, 25))
    board = BoardGeometry(outline=outline, copper=(wall_,) + pads, edge_clearance=mm(0.2))
    ends = [End(mm(x), mm(2), top, mm(0.15)) for x in (5, 25)]
    return board, [Connection("A", *ends)], {"A": NetRule(mm(0.2), mm(0.2), mm(0.6), mm(0.3))}


def test_the_variant_takes_a_layered_way_where_the_walkaround_leg_is_a_detour():
    board, connections, rules = _detour_board()
    both = ("F.Cu", "B.Cu")
    negotiator = Negotiator(board, both, rules, connections)
    # the first plan: the walkaround leg on the layer both ends are on, however long
    first = negotiator._way(negotiator._router(), 0)
    assert first is not None and len(first.legs) == 1 and first.length > mm(60)
    # the second variant: a leg longer than DETOUR times the distance gives way to the
    # layered search's way where that costs less (its length and a via cost per via)
    negotiator._detour_limit = negotiator.detour
    later = negotiator._way(negotiator._router(), 0)
    assert later is not None and len(later.vias) == 2 and {lay for lay, _ in later.legs} == {
        "F.Cu", "B.Cu"}
    assert later.length + 2 * negotiator.via_cost < first.length
    assert_legal(board, later.items(rules["A"], both))
    # a leg within the limit is kept without a layered search
    calls = negotiator.calls
    negotiator._detour_limit = 3.5
    assert negotiator._way(negotiator._router(), 0) == first and negotiator.calls == calls + 1
    # where vias cost more than the detour saves, the leg stays
    dear = Negotiator(board, both, rules, connections, via_cost=mm(30))
    dear._detour_limit = dear.detour
    assert dear._way(dear._router(), 0) == first
    # whether a connection is boxed in is asked of any way: the leg answers it, however long
    calls = negotiator.calls
    negotiator._detour_limit = negotiator.detour
    assert not negotiator._boxed(0) and negotiator.calls == calls + 1
    assert negotiator._detour_limit == negotiator.detour
    # a plan the first variant completes is the plan: the leg
    plan = Negotiator(board, both, rules, connections).run()
    assert plan.open == {} and plan.wires[0] == first and plan.stats["rounds"] == 1


class _Variants(Negotiator):
    """`run` with each plan given: the open connections of the first plan and of the second
    variant; records the detour limit and the budgets each was made under."""

    def __init__(self, opens, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.opens, self.made = list(opens), []

    def _negotiate(self):
        self.made.append((self._detour_limit, self.budget_work - self.work, self.repair_work))
        return Plan({}, dict(self.opens.pop(0)), {"rips": 0})


def test_a_second_variant_with_the_detour_rule_is_made_where_the_plan_leaves_one_open():
    board, connections, rules = _detour_board()
    both = ("F.Cu", "B.Cu")
    args = (board, both, rules, connections)
    inf, budgets = float("inf"), (BUDGET_WORK, REPAIR_WORK)
    complete = _Variants([{}], *args)
    assert complete.run().open == {} and complete.made == [(inf, *budgets)]
    fewer = _Variants([{0: "congestion", 1: "budget"}, {1: "congestion"}], *args)
    plan = fewer.run()
    assert fewer.made == [(inf, *budgets), (DETOUR, VARIANT_WORK, VARIANT_REPAIR_WORK)]
    assert plan.open == {1: "congestion"} and plan.stats["variant"] == 1
    assert fewer._detour_limit == inf and fewer.repair_work == REPAIR_WORK
    same = _Variants([{0: "congestion"}, {1: "congestion"}], *args)
    plan = same.run()
    assert plan.open == {0: "congestion"} and plan.stats["variant"] == 0
    # nothing for it to do: every open connection boxed in, one layer, or turned off
    for variants, where in ((_Variants([{0: "boxed_in"}], *args), both),
                            (_Variants([{0: "congestion"}], *args[:1], LAYERS, *args[2:]), LAYERS),
                            (_Variants([{0: "congestion"}], *args, variant_work=0), both)):
        assert len(variants.run().open) == 1 and len(variants.made) == 1, where
    # the caller's repair allowance bounds the variant's
    small = _Variants([{0: "congestion"}, {}], *args, repair_work=5)
    small.run()
    assert small.made[1][2] == 5

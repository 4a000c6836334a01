"""The negotiated agent (`--agent negotiated`): plans every open connection of the board at once
with rip-up and reroute (`pcbdata.router.negotiate`), then lays the plan through the
environment's actions.

It reads the board once, at its first step, through the environment's read-only plain-data view
(`RoutingEnv.board_view`, handed over by the runner through `attach`); every piece of copper
reaches KiCad through actions, in pcbdata's free-coordinate form: per run of wires of one net
that begin where the one before ended (`chains`) `net_select`, `start_route` at the first
wire's first pad centre (with its layer), `make_line` to each corner (one step where two
segments are the straight-then-45-degrees line `mark_obstacles` lays, `line_ends`) and
`make_via` at each via in `mark_obstacles` mode (the line exactly as planned: the planner kept
the clearance), and `net_end`; a run whose net the observation shows joined already is left
out. A via where one of the net stands already is not laid twice: the run ends on that via and
starts again from it on the via's other layer. A run whose step the environment refuses is
abandoned at that step (`net_end` takes up what it left dangling) and the agent goes on with
the next one. The plan is deterministic (counted work), so a board and a seed always give the
same episode.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import cast

from pcbdata.env.types import (
    MAKE_LINE,
    MAKE_VIA,
    MARK_OBSTACLES,
    NET_END,
    NET_SELECT,
    START_ROUTE,
    BoardView,
)
from pcbdata.router.connections import End, seeded_order, spanning_connections
from pcbdata.router.geometry import BoardGeometry
from pcbdata.router.negotiate import BUDGET_ROUTES, CAUSES, Negotiator, NetRule, Plan, Wire
from pcbdata.router.requests import mark_obstacles_path


def _mm(point) -> tuple[float, float]:
    return point[0] / 1e6, point[1] / 1e6


def _nm(action: dict) -> tuple[int, int]:
    """An action's point back in nm, as the environment reads it."""
    return int(round(action["x"] * 1e6)), int(round(action["y"] * 1e6))


def plan_board(view: BoardView, budget_routes: int = BUDGET_ROUTES, seed: int = 0,
               **options) -> tuple[Plan, list]:
    """The negotiated plan of a board's open connections and those connections, as planned
    (an end whose pad centre no track can start at moved to an access point; seed 0:
    shortest first; another seed: another order, `negotiate.seeded_order`); `options` go to
    `Negotiator` (max_rips, restarts, router budgets)."""
    static = view.static
    routed = {n.name for n in static.nets if n.name}
    pads = []
    for i, pad in enumerate(static.pads):
        if pad.net not in routed or len(static.pads_of(pad.net)) < 2:
            continue
        reach = max(pad.size) // 2
        pads.append((pad.net, End(pad.x, pad.y, tuple(static.layers[k] for k in pad.layers),
                                  reach), view.pad_cluster[i]))
    connections = seeded_order(spanning_connections(pads), seed)
    rules = {n.name: NetRule(n.track_width, n.clearance, n.via_diameter, n.via_drill)
             for n in static.nets}
    layers = static.layers if static.grid_pitch is None else static.layers[:1]
    negotiator = Negotiator(view.geometry, layers, rules, connections,  # type: ignore[arg-type]
                            budget_routes=budget_routes, **options)
    return negotiator.run(), negotiator.connections


def wire_actions(view: BoardView, wire: Wire, then: tuple[Wire, ...] = ()) -> list[dict]:
    """The actions that lay one wire, from `net_select` to `net_end`, and after it the wires
    `then`, each beginning where the one before ended, on its layer (no new start)."""
    static = view.static
    layer = {name: i for i, name in enumerate(static.layers)}
    first_layer, first_path = wire.legs[0]
    x, y = _mm(first_path[0])
    out: list[dict] = [{"type": NET_SELECT, "net": static.net_index(wire.net)},
                       {"type": START_ROUTE, "x": x, "y": y, "layer": layer[first_layer]}]
    for each in (wire, *then):
        out += _drawing(each, layer)
    out.append({"type": NET_END})
    return out


def line_ends(path) -> list:
    """The points `make_line` goes to, in order, to lay `path` from its first point: each
    corner, but where the next two segments are the straight-then-45-degrees line that
    `mark_obstacles` lays from the current point to the one after, one step to that point
    (the same copper, one copper-changing step fewer)."""
    ends, here, i = [], tuple(path[0]), 1
    while i < len(path):
        if i + 1 < len(path) and mark_obstacles_path(here, tuple(path[i + 1])) == (
                here, tuple(path[i]), tuple(path[i + 1])):
            i += 1
        ends.append(tuple(path[i]))
        here = ends[-1]
        i += 1
    return ends


def _drawing(wire: Wire, layer: dict[str, int]) -> list[dict]:
    out = []
    for i, (_, path) in enumerate(wire.legs):
        via = i < len(wire.vias)
        ends = line_ends(path)
        if via and ends:  # `make_via` lays the line to the via's point itself
            ends.pop()
        for point in ends:
            px, py = _mm(point)
            out.append({"type": MAKE_LINE, "x": px, "y": py, "mode": MARK_OBSTACLES})
        if via:
            vx, vy = _mm(wire.vias[i])
            out.append({"type": MAKE_VIA, "x": vx, "y": vy, "mode": MARK_OBSTACLES,
                        "layer": layer[wire.legs[i + 1][0]]})
    return out


def chains(wires: list[Wire]) -> list[tuple[Wire, ...]]:
    """The wires in runs of one net, each wire of a run beginning where the one before it
    ended, on that layer (a wire turned round where that makes it so): a run is laid from one
    start, which saves the steps of releasing the net and starting again. Runs keep the order
    of their first wires."""
    by_net: dict[str, list[Wire]] = {}
    for wire in wires:
        by_net.setdefault(wire.net, []).append(wire)
    runs = []
    for wire in wires:
        todo = by_net[wire.net]
        if wire not in todo:
            continue
        todo.remove(wire)
        run = [wire]
        while True:
            layer_, path = run[-1].legs[-1]
            head = (layer_, path[-1])
            found = next(((k, w) for k, original in enumerate(todo)
                          for w in (original, _turned(original))
                          if (w.legs[0][0], w.legs[0][1][0]) == head), None)
            if found is None:
                break
            run.append(found[1])
            todo.pop(found[0])
        runs.append(tuple(run))
    return runs


def _turned(wire: Wire) -> Wire:
    return Wire(wire.net, tuple((lay, tuple(reversed(path))) for lay, path in
                                reversed(wire.legs)), tuple(reversed(wire.vias)))


def _net_open(obs, net: int) -> bool:
    """Whether the observation's ratsnest still has an open connection of `net` (True when
    the list is cut at its capacity: it may not show them all)."""
    geometry = obs["routing_geometry"]
    rows, count = geometry["ratsnest"], int(geometry["ratsnest_count"])
    if count >= len(rows):
        return True
    return bool(any(int(row[1]) == net for row in rows[:count] if row[0]))


class NegotiatedAgent:
    """`act(obs, info)` over the environment's actions; see the module doc."""

    def __init__(self, seed: int = 0, budget_routes: int = BUDGET_ROUTES):
        self.seed = seed
        self.budget_routes = budget_routes
        self._view: Callable[[], BoardView] | None = None
        self._queue: list[list[dict]] = []
        self._current: list[dict] = []
        self._planned = False
        self.plan: Plan | None = None
        self.done = False
        self.refused_wires = self.skipped_wires = self.reused_vias = 0
        self._reset_tracking()

    def _reset_tracking(self) -> None:
        self._vias: set[tuple[int, tuple[int, int]]] = set()  # (net index, nm) of laid vias
        self._net: int | None = None
        self._head: tuple[int, int] | None = None
        self._sent_via: tuple[int, tuple[int, int]] | None = None

    def attach(self, env) -> None:
        """The runner hands over the environment (its `board_view` only is read)."""
        self._view = env.board_view
        self._queue, self._current, self._planned, self.done = [], [], False, False
        self.refused_wires = self.skipped_wires = self.reused_vias = 0
        self._reset_tracking()

    def act(self, obs, info) -> dict:
        if not self._planned:
            self._make_plan()
        if self._sent_via is not None:  # the last step laid a via unless it was refused
            if not self._refused(info):
                self._vias.add(self._sent_via)
            self._sent_via = None
        if self._current and self._refused(info):
            self.refused_wires += 1
            self._current = [{"type": NET_END}] if info.get("phase") != "no_net" else []
        while not self._current:
            if not self._queue:
                self.done = True
                return {"type": NET_END} if info.get("phase") != "no_net" else {"type": 0}
            wire = self._queue.pop(0)
            if _net_open(obs, wire[0]["net"]):
                self._current = wire
            else:  # joined already through other copper: laying it would only add copper
                self.skipped_wires += 1
        return self._followed(self._current.pop(0))

    def _followed(self, action: dict) -> dict:
        """`action`, after noting the net it selects and the point it moves the head to; a
        `make_via` where a via of the net stands already (two wires of a net changing layer at
        one point, or the board's own via) becomes a line to that via and a new start on it at
        the via's other layer: a second via there would be a co-located hole."""
        kind = action["type"]
        if kind == NET_SELECT:
            self._net = int(action["net"])
        if kind not in (START_ROUTE, MAKE_LINE, MAKE_VIA):
            return action
        point = _nm(action)
        if kind == MAKE_VIA and self._net is not None:
            if (self._net, point) in self._vias:
                self.reused_vias += 1
                xy = {"x": action["x"], "y": action["y"]}
                steps: list[dict] = [{"type": NET_END}, {"type": NET_SELECT, "net": self._net},
                                     {"type": START_ROUTE, **xy, "layer": action["layer"]}]
                if self._head != point:
                    steps.insert(0, {"type": MAKE_LINE, **xy, "mode": MARK_OBSTACLES})
                self._current[:0] = steps
                return self._followed(self._current.pop(0))
            self._sent_via = (self._net, point)
        self._head = point
        return action

    def report(self) -> dict:
        """The plan's counts for the rollout's JSON: connections, the open ones by cause
        (`negotiate.CAUSES`), route calls, rip-ups, rounds, wires the environment refused,
        wires left out because their net was joined already and vias laid once for two wires."""
        if self.plan is None:
            return {}
        causes = {c: sum(1 for v in self.plan.open.values() if v == c) for c in CAUSES}
        return {**self.plan.stats, "open": causes, "refused_wires": self.refused_wires,
                "skipped_wires": self.skipped_wires, "reused_vias": self.reused_vias}

    @staticmethod
    def _refused(info) -> bool:
        router = info.get("router") or {}
        return bool(info.get("rejected")) or router.get("ok") is False

    def _make_plan(self) -> None:
        if self._view is None:
            raise RuntimeError("NegotiatedAgent needs the environment: call attach(env) first")
        view = self._view()
        named = {n.name for n in view.static.nets if n.name}
        self._vias = {(view.static.net_index(item.net), item.start)
                      for item in cast(BoardGeometry, view.geometry).copper
                      if item.kind == "via" and item.net in named and item.start is not None}
        self.plan, _ = plan_board(view, self.budget_routes, self.seed)
        wires = [w for _, w in sorted(self.plan.wires.items())]
        self._queue = [wire_actions(view, run[0], run[1:]) for run in chains(wires)]
        self._planned = True

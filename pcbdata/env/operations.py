"""The routing operations (make_line, make_via, finish) as edits for the KiCad session.

Geometry is pcbdata's: `walkaround` asks the walkaround router (`pcbdata.router.walkaround`) for a
legal octilinear path; `mark_obstacles` lays the straight or two-segment octilinear line as
asked, violations allowed; `push_n_shove` takes up other nets' tracks in the way and joins
those nets again around the new path (`pcbdata.router.shove`). KiCad then holds the copper and
judges it. An operation that cannot be done changes nothing and says why.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from pcbdata.env.types import (
    MARK_OBSTACLES,
    MODES,
    PUSH_N_SHOVE,
    WALKAROUND,
    Head,
    NetRules,
    StaticBoard,
)
from pcbdata.router import shove
from pcbdata.router.geometry import CopperItem
from pcbdata.router.requests import RouteRequest, mark_obstacles_path


@dataclass
class Outcome:
    ok: bool
    reason: str = ""
    edits: list = field(default_factory=list)
    head: Head | None = None
    stats: dict = field(default_factory=dict)
    side: list = field(default_factory=list)  # push_n_shove: other nets' removals and reroutes
    moved: tuple[str, ...] = ()  # push_n_shove: the nets whose tracks it moved


def octilinear_line(start, goal) -> tuple:
    """The mark-obstacles line: straight when the direction is a multiple of 45 degrees, else
    a straight then a diagonal segment (`walkaround.mark_obstacles_path`)."""
    return mark_obstacles_path((int(start[0]), int(start[1])), (int(goal[0]), int(goal[1])))


def via_layer(static: StaticBoard, layer: int, target: int | None = None) -> int:
    """The layer a via takes the head to: `target` (a layer the candidate names), else the
    other outer copper layer."""
    if target is not None and target != layer:
        return target
    return len(static.layers) - 1 if layer == 0 else 0


def _request(net: NetRules, layer: str, start, goal) -> RouteRequest:
    return RouteRequest(net=net.name, layer=layer, start=(int(start[0]), int(start[1])),
                        goal=(int(goal[0]), int(goal[1])), width=net.track_width,
                        clearance=net.clearance)


def _path(static: StaticBoard, router, mode: int, net: NetRules, layer: str, start, goal,
          budget, extra: tuple = ()) -> Outcome:
    if mode == MARK_OBSTACLES:
        return Outcome(True, edits=[octilinear_line(start, goal)])
    if mode == PUSH_N_SHOVE:
        return _shove_path(static, router, net, layer, start, goal, budget, extra)
    began = time.perf_counter()
    result = router().route(_request(net, layer, start, goal))
    budget.append(time.perf_counter() - began)
    stats = deterministic_stats(result.stats)
    if result.path is None:
        return Outcome(False, f"walkaround: {result.reason or 'no path'}", stats=stats)
    path = tuple(tuple(int(v) for v in p) for p in result.path)
    if not path or path[0] != tuple(start) or path[-1] != tuple(goal):
        return Outcome(False, "walkaround: the router's path does not join the head to the goal",
                       stats=stats)
    return Outcome(True, edits=[path], stats=stats)


def _shove_path(static: StaticBoard, router, net: NetRules, layer: str, start, goal, budget,
                extra) -> Outcome:
    began = time.perf_counter()
    planned = shove.plan(router(), _request(net, layer, start, goal), extra, _via_rules(static))
    budget.append(time.perf_counter() - began)
    stats = deterministic_stats(planned.stats)
    if planned.path is None:
        return Outcome(False, planned.reason, stats=stats)
    side = [remove_edit(item) for item in planned.removed]
    side += [{"kind": "track", "net": r.net, "layer": r.layer or layer, "points": list(r.path),
              "width": r.width} for r in planned.reroutes]
    side += [{"kind": "via", "net": v.net, "at": tuple(v.at), "diameter": v.diameter,
              "drill": v.drill} for v in planned.vias]
    return Outcome(True, edits=[planned.path], stats=stats, side=side, moved=planned.moved_nets)


def _via_rules(static: StaticBoard) -> shove.ViaRules:
    """Every copper layer (a via spans them) and each net's own via, for re-joins."""
    sizes = {n.name: (n.via_diameter, n.via_drill) for n in static.nets}
    largest = max(sizes.values(), default=(0, 0))
    return shove.ViaRules(tuple(static.layers), lambda name: sizes.get(name, largest))


def remove_edit(item: CopperItem) -> dict:
    """The edit that takes one straight track up (one KiCad track of that net, layer, ends and
    width: a track drawn twice needs two edits)."""
    return {"kind": "remove", "net": item.net, "layer": item.layers[0], "start": item.start,
            "end": item.end, "width": item.width}


def undo(edits: list[dict]) -> list[dict]:
    """Edits that take the board back to where it was before `edits`."""
    out: list[dict] = []
    for edit in reversed(edits):
        if edit["kind"] == "track":
            points = edit["points"]
            out += [{"kind": "remove", "net": edit["net"], "layer": edit["layer"], "start": a,
                     "end": b, "width": edit["width"]}
                    for a, b in reversed(list(zip(points, points[1:]))) if tuple(a) != tuple(b)]
        elif edit["kind"] == "via":
            out.append({"kind": "remove_via", "net": edit["net"], "at": edit["at"]})
        elif edit["kind"] == "remove_via":  # a pruned via (`routing_session.prune`)
            out.append({"kind": "via", "net": edit["net"], "at": edit["at"],
                        "diameter": edit["diameter"], "drill": edit["drill"]})
        else:
            out.append({"kind": "track", "net": edit["net"], "layer": edit["layer"],
                        "points": [edit["start"], edit["end"]], "width": edit["width"]})
    return out


def lost_connections(before: dict, after: dict, nets) -> list[str]:
    """The moved nets with more pad clusters after an edit than before (KiCad's count)."""
    return [net for net in nets if after.get(net, 0) > before.get(net, 0)]


def deterministic_stats(stats) -> dict:
    """The router's counters without wall-clock values: `info` must be the same on every run
    (Gymnasium's determinism check compares it)."""
    clocks = ("time", "second", "elapsed", "_ms", "_s")
    return {str(k): v for k, v in sorted(dict(stats or {}).items())
            if isinstance(v, (bool, int, str)) and not any(c in str(k) for c in clocks)}


def _track_edit(net: NetRules, layer: str, points) -> dict:
    return {"kind": "track", "net": net.name, "layer": layer, "points": [tuple(p) for p in points],
            "width": net.track_width}


def make_line(static, router, net: NetRules, head: Head, goal, mode: int, times,
              extra: tuple = ()) -> Outcome:
    layer = static.layers[head.layer]
    found = _path(static, router, mode, net, layer, (head.x, head.y), goal, times, extra)
    if not found.ok:
        return found
    edits = [_track_edit(net, layer, found.edits[0])] if tuple(goal) != (head.x, head.y) else []
    return Outcome(True, edits=found.side + edits, head=Head(goal[0], goal[1], head.layer),
                   stats=found.stats, moved=found.moved)


def make_via(static, router, net: NetRules, head: Head, goal, mode: int, times,
             target: int | None = None) -> Outcome:
    """`make_line` to `goal`, then a through via there; the head goes to `via_layer`."""
    if mode != MARK_OBSTACLES and not router().via_fits(
            net.name, tuple(goal), net.via_diameter, net.clearance, tuple(static.layers)):
        because = "" if mode == WALKAROUND else "; tracks are moved for the line, not the via"
        return Outcome(False, f"{MODES[mode]}: the via does not fit there (clearance{because})")
    at = (int(goal[0]), int(goal[1]))
    via_item = CopperItem(kind="via", net=net.name, layers=tuple(static.layers), start=at, end=at,
                          width=net.via_diameter, clearance=net.clearance)
    line = make_line(static, router, net, head, goal, mode, times, (via_item,))
    if not line.ok:
        return line
    via = {"kind": "via", "net": net.name, "at": tuple(goal), "diameter": net.via_diameter,
           "drill": net.via_drill}
    return Outcome(True, edits=line.edits + [via],
                   head=Head(goal[0], goal[1], via_layer(static, head.layer, target)),
                   stats=line.stats,
                   moved=line.moved)


def finish(static, router, net: NetRules, head: Head, targets: list[tuple[int, int]], mode: int,
           tries: int, times) -> Outcome:
    """Routes from the head to the nearest of `targets` (pad centres on the head's layer, not yet
    joined to the head's copper) that the mode reaches; at most `tries` targets are tried."""
    if not targets:
        return Outcome(False, "finish: no unconnected pad of the net on the head's layer")
    order = sorted(targets, key=lambda t: ((t[0] - head.x) ** 2 + (t[1] - head.y) ** 2, t))
    reasons = []
    for goal in order[: max(1, tries)]:
        done = make_line(static, router, net, head, goal, mode, times)
        if done.ok:
            return done
        reasons.append(done.reason)
    return Outcome(False, f"finish: no path to the {len(reasons)} nearest pads ({reasons[0]})")

"""push_n_shove (SPEC section 6): pcbdata's rip-up and reroute, planned on plain geometry.

KiCad's own push-and-shove router is not exported by Debian's KiCad, so this mode is ours and
KiCad stays the judge. A request is planned in three steps:

1. If the walkaround router finds a path on the board as it is, that path is the answer
   (nothing needs to move).
2. Otherwise the path is searched on the board without other nets' straight tracks on the
   request's layer (pads, vias, arcs, zones, no-net copper and the edge stay obstacles). The
   tracks that path would pass too close to are the *blockers*.
3. The blockers are taken up, and each place where a blocker touched the rest of its net's
   copper is joined again by the walkaround router, on the same layer, around the new path and
   everything else (blocking nets in name order, each new path an obstacle to the next). If any
   net cannot be joined again, the plan fails and the board stays as it was.

Every new path is a walkaround path, so it keeps clearance by construction; the environment
then applies the plan in one KiCad round trip and undoes it if KiCad's connectivity shows that
a moved net lost a connection (`pcbdata.env.routing`). Nothing here imports KiCad.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import shapely

from pcbdata.router.geometry import BoardGeometry, CopperItem, Point, copper_core
from pcbdata.router.walkaround import TOLERANCE, RouteRequest, WalkaroundRouter


@dataclass(frozen=True)
class Reroute:
    """A new path for a moved net (its tracks' width, on the request's layer)."""

    net: str
    path: tuple[Point, ...]
    width: int


@dataclass(frozen=True)
class ShovePlan:
    path: tuple[Point, ...] | None  # the requested path; None: no plan (see reason)
    reason: str = ""
    removed: tuple[CopperItem, ...] = ()  # other nets' tracks taken up, sorted
    reroutes: tuple[Reroute, ...] = ()
    stats: dict = field(default_factory=dict)

    @property
    def moved_nets(self) -> tuple[str, ...]:
        return tuple(sorted({item.net for item in self.removed}))


def plan(router: WalkaroundRouter, request: RouteRequest,
         extra: tuple[CopperItem, ...] = ()) -> ShovePlan:
    """The push_n_shove plan for `request` on `router`'s board. `extra`: copper of the request's
    net that will be added with the path (a via at the goal), which the moved nets must avoid."""
    direct = router.route(request)
    if direct.path is not None:
        return ShovePlan(direct.path, stats={**direct.stats, "shove": "not_needed"})
    board = router.board
    movable = _movable(board, request)
    if not movable:
        return _failed(f"walkaround: {direct.reason}; no other net's track to move", direct)
    opened = router.with_board(_without(board, movable)).route(request)
    if opened.path is None:
        return _failed(f"not even with other nets' tracks moved: {opened.reason}", opened)
    blockers = _blocking(opened.path, request, movable)
    if not blockers:  # the first search ran out of budget where this one did not
        return ShovePlan(opened.path, stats={**opened.stats, "shove": "not_needed"})
    return _reroute(router, request, opened.path, blockers, extra)


def _failed(reason: str, result) -> ShovePlan:
    return ShovePlan(None, f"push_n_shove: {reason}", stats=dict(result.stats))


def _movable(board: BoardGeometry, request: RouteRequest) -> list[CopperItem]:
    """Other nets' straight tracks on the request's layer: the copper this mode may move (a
    track drawn twice is two KiCad tracks, so it stays twice: each needs its removal)."""
    return sorted((item for item in board.copper
                   if item.kind == "track" and item.net not in ("", request.net)
                   and request.layer in item.layers),
                  key=_track_key)


def _track_key(item: CopperItem) -> tuple:
    return (item.net, item.start, item.end, item.width)


def _without(board: BoardGeometry, items) -> BoardGeometry:
    gone = set(items)
    return replace(board, copper=tuple(i for i in board.copper if i not in gone))


def _with(board: BoardGeometry, items) -> BoardGeometry:
    return replace(board, copper=board.copper + tuple(items))


def _blocking(path, request: RouteRequest, movable: list[CopperItem]) -> list[CopperItem]:
    """The movable tracks closer to the path than the rules allow (exact distances)."""
    line = shapely.LineString(path) if len(path) > 1 else shapely.Point(path[0])
    out = []
    for item in movable:
        core, radius = copper_core(item)
        need = radius + request.width / 2 + max(request.clearance, item.clearance) - TOLERANCE
        if shapely.distance(line, core) < need:
            out.append(item)
    return out


def path_items(net: str, layer: str, path, width: int, clearance: int) -> list[CopperItem]:
    """The tracks a path becomes (one per segment), as the router sees copper."""
    return [CopperItem(kind="track", net=net, layers=(layer,), start=tuple(a), end=tuple(b),
                       width=width, clearance=clearance)
            for a, b in zip(path, path[1:]) if tuple(a) != tuple(b)]


def _reroute(router: WalkaroundRouter, request: RouteRequest, path, blockers, extra) -> ShovePlan:
    ours = path_items(request.net, request.layer, path, request.width, request.clearance)
    board = _with(_without(router.board, blockers), ours + list(extra))
    reroutes: list[Reroute] = []
    expanded = 0
    for net in sorted({b.net for b in blockers}):
        taken = [b for b in blockers if b.net == net]
        for group in _groups(taken):
            ends = _attachments(group, board)
            width, clearance = max(t.width for t in group), max(t.clearance for t in group)
            for goal in ends[1:]:
                found = router.with_board(board).route(RouteRequest(
                    net=net, layer=request.layer, start=ends[0], goal=goal, width=width,
                    clearance=clearance))
                expanded += int(found.stats.get("expanded", 0))
                if found.path is None:
                    return ShovePlan(None, f"push_n_shove: net {net!r} cannot be joined again "
                                           f"around the new path ({found.reason})",
                                     stats={"method": "shove", "expanded": expanded})
                reroutes.append(Reroute(net, tuple(found.path), width))
                board = _with(board, path_items(net, request.layer, found.path, width, clearance))
    stats = {"method": "shove", "moved_tracks": len(blockers), "expanded": expanded,
             "moved_nets": len({b.net for b in blockers}), "reroutes": len(reroutes)}
    return ShovePlan(tuple(path), removed=tuple(blockers), reroutes=tuple(reroutes), stats=stats)


def _groups(tracks: list[CopperItem]) -> list[list[CopperItem]]:
    """Tracks joined end to end, as groups (in the order of their first track)."""
    groups: list[list[CopperItem]] = []
    for track in tracks:
        touching = [g for g in groups if any(_share_end(track, t) for t in g)]
        merged = [track] + [t for g in touching for t in g]
        groups = [g for g in groups if g not in touching] + [sorted(merged, key=_track_key)]
    return sorted(groups, key=lambda g: _track_key(g[0]))


def _share_end(a: CopperItem, b: CopperItem) -> bool:
    return bool({a.start, a.end} & {b.start, b.end})


def _attachments(group: list[CopperItem], board: BoardGeometry) -> list[Point]:
    """The ends of a group of taken-up tracks where the rest of their net's copper (still on
    `board`) touches them: the places a new path must join again. Sorted."""
    points = sorted({p for t in group for p in (t.start, t.end) if p is not None})
    net, layer = group[0].net, group[0].layers[0]
    own = [i for i in board.copper if i.net == net and layer in i.layers]
    return [p for p in points if any(_touches(i, p) for i in own)]


def _touches(item: CopperItem, point: Point) -> bool:
    """Whether KiCad joins a track end at `point` to `item`: the end of a track or arc, a point
    inside a via, pad or zone (a point merely within a track's width is not joined)."""
    if item.kind in ("track", "arc"):
        return point in (item.start, item.end)
    if item.kind == "graphic":
        return False
    core, radius = copper_core(item)
    return shapely.distance(core, shapely.Point(point)) <= radius

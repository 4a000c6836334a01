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
   everything else (blocking nets in name order, each new path an obstacle to the next). Where
   the same layer has no way round (the new path cuts the moved net off, as between the pads of
   a fine-pitch row), the join may hop to another copper layer through one via of the moved
   net's size, placed on the taken-up track's way, when the far end reaches that layer (a
   through-hole pad, a via); where neither end does, under the new path: a via near each end
   and a leg on another layer between them. If any net cannot be joined again, the plan fails
   and the board stays as it was.

Every new path is a walkaround path, so it keeps clearance by construction; the environment
then applies the plan in one KiCad round trip and undoes it if KiCad's connectivity shows that
a moved net lost a connection (`pcbdata.env.operations`). Nothing here imports KiCad.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import shapely

from pcbdata.router.clearance import HEADINGS, TOLERANCE
from pcbdata.router.geometry import BoardGeometry, CopperItem, Point, copper_core
from pcbdata.router.requests import RouteRequest
from pcbdata.router.walkaround import WalkaroundRouter


@dataclass(frozen=True)
class Reroute:
    """A new path for a moved net (its tracks' width; layer "": the request's layer)."""

    net: str
    path: tuple[Point, ...]
    width: int
    layer: str = ""


@dataclass(frozen=True)
class ViaDrop:
    """A through via a re-join hops layers with."""

    net: str
    at: Point
    diameter: int
    drill: int


@dataclass(frozen=True)
class ViaRules:
    """What a re-join through a via needs: the board's copper layers (a via spans them all)
    and each net's via (net name -> diameter, drill)."""

    layers: tuple[str, ...]
    via_of: Callable[[str], tuple[int, int]]


#: Places along a taken-up track a via re-join looks at, nearest the cut-off end first, and
#: their spacing (nm): enough to step out of a fine-pitch row. Of those where the via fits, at
#: most VIA_TRIES are routed to (a failed search is the dearest thing the router does).
VIA_SPOTS = 12
VIA_SPOT_STEP = 250_000
VIA_TRIES = 2
#: A re-join under the cut (a via near each end) also looks beside those places, this far
#: away in the eight directions (nm).
UNDER_OFFSETS = (500_000, 1_000_000)


@dataclass(frozen=True)
class ShovePlan:
    path: tuple[Point, ...] | None  # the requested path; None: no plan (see reason)
    reason: str = ""
    removed: tuple[CopperItem, ...] = ()  # other nets' tracks taken up, sorted
    reroutes: tuple[Reroute, ...] = ()
    vias: tuple[ViaDrop, ...] = ()  # re-joins' layer hops
    stats: dict = field(default_factory=dict)

    @property
    def moved_nets(self) -> tuple[str, ...]:
        return tuple(sorted({item.net for item in self.removed}))


def plan(router: WalkaroundRouter, request: RouteRequest,
         extra: tuple[CopperItem, ...] = (), vias: ViaRules | None = None) -> ShovePlan:
    """The push_n_shove plan for `request` on `router`'s board. `extra`: copper of the request's
    net that will be added with the path (a via at the goal), which the moved nets must avoid;
    `vias`: the layers and via sizes a re-join may hop layers with (None: same layer only)."""
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
    return _reroute(router, request, opened.path, blockers, extra, vias)


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


def _reroute(router: WalkaroundRouter, request: RouteRequest, path, blockers, extra,
             vias: ViaRules | None) -> ShovePlan:
    ours = path_items(request.net, request.layer, path, request.width, request.clearance)
    board = _with(_without(router.board, blockers), ours + list(extra))
    reroutes: list[Reroute] = []
    drops: list[ViaDrop] = []
    joins: list[_Join] = []
    under = 0  # re-joins on another layer with a via near each end
    for net in sorted({b.net for b in blockers}):
        taken = [b for b in blockers if b.net == net]
        for group in _groups(taken):
            ends = _attachments(group, board)
            join = _Join(router, net, request.layer, max(t.width for t in group),
                         max(t.clearance for t in group))
            joins.append(join)
            for goal in ends[1:]:
                found = join.route(board, request.layer, ends[0], goal)
                if found.path is not None:
                    reroutes.append(Reroute(net, tuple(found.path), join.width))
                    board = _with(board, join.items(request.layer, found.path))
                    continue
                hop = join.through_via(board, group, ends[0], goal, vias) if vias else None
                if hop is None and vias:
                    hop = join.under(board, group, ends[0], goal, vias)
                    under += hop is not None
                if hop is None:
                    return ShovePlan(None, f"push_n_shove: net {net!r} cannot be joined again "
                                           f"around the new path ({found.reason})",
                                     stats={"method": "shove",
                                            "expanded": sum(j.expanded for j in joins)})
                legs, dropped, board = hop
                reroutes += legs
                drops += dropped
    expanded = sum(j.expanded for j in joins)
    stats = {"method": "shove", "moved_tracks": len(blockers), "expanded": expanded,
             "moved_nets": len({b.net for b in blockers}), "reroutes": len(reroutes),
             "rejoin_vias": len(drops), "rejoins_under": under}
    return ShovePlan(tuple(path), removed=tuple(blockers), reroutes=tuple(reroutes),
                     vias=tuple(drops), stats=stats)


@dataclass
class _Join:
    """Re-joining one moved net: same-layer paths, or two legs and a via between layers."""

    router: WalkaroundRouter
    net: str
    layer: str
    width: int
    clearance: int
    expanded: int = 0  # search nodes expanded by its routes

    def route(self, board: BoardGeometry, layer: str, start: Point, goal: Point):
        found = self.router.with_board(board).route(RouteRequest(
            net=self.net, layer=layer, start=start, goal=goal, width=self.width,
            clearance=self.clearance))
        self.expanded += int(found.stats.get("expanded", 0))
        return found

    def items(self, layer: str, path) -> list[CopperItem]:
        return path_items(self.net, layer, path, self.width, self.clearance)

    def through_via(self, board: BoardGeometry, group, a: Point, b: Point, vias: ViaRules):
        """(legs, [via], board with them) joining a and b with one layer hop, or None. The via
        sits on the taken-up tracks' way, nearest the end that stays on this layer; the far
        end must reach the other layer."""
        diameter, drill = vias.via_of(self.net)
        here = self.router.with_board(board)
        for near, far in ((a, b), (b, a)):
            others = [la for la in vias.layers
                      if la != self.layer and _reaches(board, self.net, far, la)]
            fitting = self._fitting(here, _via_spots(group, near), vias) if others else []
            for other in others:
                for at in fitting:
                    hop = self._hop(board, near, far, at, other, diameter, vias.layers)
                    if hop is not None:
                        legs, board_after = hop
                        return legs, [ViaDrop(self.net, at, diameter, drill)], board_after
        return None

    def under(self, board: BoardGeometry, group, a: Point, b: Point, vias: ViaRules):
        """(legs, vias, board with them) joining a and b on another layer, under the cut: a
        via on the taken-up tracks' way near each end, or None."""
        diameter, drill = vias.via_of(self.net)
        here = self.router.with_board(board)
        spots = {end: self._fitting(here, _spots_around(_via_spots(group, end), end), vias)
                 for end in (a, b)}
        apart = diameter + self.clearance  # two holes of one net need room between them too
        for other in [layer for layer in vias.layers if layer != self.layer]:
            for at_a in spots[a]:
                for at_b in spots[b]:
                    if _distance(at_a, at_b) < apart:
                        continue
                    found = self._under(board, (a, at_a, at_b, b), other, diameter,
                                        vias.layers)
                    if found is not None:
                        drops = [ViaDrop(self.net, at, diameter, drill) for at in (at_a, at_b)]
                        return found[0], drops, found[1]
        return None

    def _fitting(self, here: WalkaroundRouter, spots: list[Point],
                 vias: ViaRules) -> list[Point]:
        """The first VIA_TRIES of `spots` where the net's via fits on `here`'s board."""
        fits = here.vias_fit(self.net, spots, vias.via_of(self.net)[0], self.clearance,
                             vias.layers)
        return [at for at, ok in zip(spots, fits) if ok][:VIA_TRIES]

    def _under(self, board, points, other, diameter, layers):
        """Legs a -> via (this layer), via -> via (`other`), via -> b (this layer)."""
        a, at_a, at_b, b = points
        legs = []
        for start, goal, layer in ((a, at_a, self.layer), (at_a, at_b, other),
                                   (at_b, b, self.layer)):
            path = (start,) if start == goal else self.route(board, layer, start, goal).path
            if path is None:
                return None
            board = _with(board, self.items(layer, path))
            if layer == other:  # both vias once the middle leg is known to exist
                board = _with(board, [self._via(at, diameter, layers) for at in (at_a, at_b)])
            legs.append(Reroute(self.net, tuple(path), self.width, layer))
        return [leg for leg in legs if len(leg.path) > 1], board

    def _via(self, at: Point, diameter: int, layers) -> CopperItem:
        return CopperItem(kind="via", net=self.net, layers=tuple(layers), start=at, end=at,
                          width=diameter, clearance=self.clearance)

    def _hop(self, board, near, far, at, other, diameter, layers):
        via_item = self._via(at, diameter, layers)
        first = (near,) if at == near else self.route(board, self.layer, near, at).path
        if first is None:
            return None
        board = _with(board, self.items(self.layer, first) + [via_item])
        second = self.route(board, other, at, far).path
        if second is None:
            return None
        board = _with(board, self.items(other, second))
        legs = [Reroute(self.net, tuple(first), self.width, self.layer),
                Reroute(self.net, tuple(second), self.width, other)]
        return [leg for leg in legs if len(leg.path) > 1], board


def _reaches(board: BoardGeometry, net: str, point: Point, layer: str) -> bool:
    """Whether the net's copper on `layer` joins a track end at `point` (a through-hole pad, a
    via)."""
    return any(_touches(item, point) for item in board.copper
               if item.net == net and layer in item.layers)


def _via_spots(group: list[CopperItem], near: Point) -> list[Point]:
    """Places along the taken-up tracks, every VIA_SPOT_STEP, nearest `near` first."""
    spots = set()
    for track in group:
        a, b = np.array(track.start, dtype=float), np.array(track.end, dtype=float)
        steps = max(1, int(np.hypot(*(b - a)) // VIA_SPOT_STEP))
        for t in np.linspace(0.0, 1.0, steps + 1):
            x, y = a + t * (b - a)
            spots.add((int(round(x)), int(round(y))))
    return sorted(spots, key=lambda p: ((p[0] - near[0]) ** 2 + (p[1] - near[1]) ** 2, p))[
        :VIA_SPOTS]


def _spots_around(spots: list[Point], near: Point) -> list[Point]:
    """The spots and points beside them (UNDER_OFFSETS along the eight headings), nearest
    `near` first: a taken-up track often runs where no via fits, beside pads."""
    steps = np.rint(HEADINGS[None] * np.array(UNDER_OFFSETS)[:, None, None]).reshape(-1, 2)
    beside = (np.array(spots)[:, None, :] + steps[None]).reshape(-1, 2).astype(np.int64)
    out = set(spots) | {(int(x), int(y)) for x, y in beside}
    return sorted(out, key=lambda p: ((p[0] - near[0]) ** 2 + (p[1] - near[1]) ** 2, p))


def _distance(a: Point, b: Point) -> float:
    return float(np.hypot(a[0] - b[0], a[1] - b[1]))


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
    if item.kind in ("graphic", "hole"):
        return False
    core, radius = copper_core(item)
    return shapely.distance(core, shapely.Point(point)) <= radius

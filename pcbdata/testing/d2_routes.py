"""Routes D2 boards net by net with the walkaround router, and checks the result exactly.

Shared by tests/router/test_walkaround.py and bench/bench_walkaround.py. Each net's pads are
joined in order (pad i to pad i+1): on a copper layer both pads are on, else through a via
next to the first pad. Every path found becomes tracks of its net, so later nets avoid it.
The legality check is independent of the router's own shapes: pads are exact circles and
rounded rectangles (a rectangle grown by the corner radius), tracks exact capsules.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import shapely

from pcbdata.generators.d2 import D2Generator
from pcbdata.model.board import Board, Pad, Track, Via
from pcbdata.router.geometry import geometry_from_board
from pcbdata.router.requests import RouteRequest
from pcbdata.router.walkaround import WalkaroundRouter
from pcbdata.sets.presets import level as preset_level

LAYERS = ("F.Cu", "B.Cu")


@dataclass
class Call:
    """One `route` call: what it cost and what it gave."""

    board: str
    net: str
    seconds: float
    method: str
    ok: bool
    reason: str


def d2_test_boards(count: int = 128) -> list[tuple[str, Board]]:
    level = preset_level("d2", "default")
    generator = D2Generator(level.params)
    return [(f"test/{i}", generator.generate(level.seed, "test", i).board) for i in range(count)]


def pad_layers(pad: Pad) -> tuple[str, ...]:
    return LAYERS if pad.kind == "thru_round" else (pad.layer,)


def route_board(name: str, board: Board, **router_options) -> tuple[Board, list[Call], int]:
    """The board with every path the router found added; the calls; connections left open."""
    board = replace(board, tracks=list(board.tracks), vias=list(board.vias))
    router = WalkaroundRouter(geometry_from_board(board), **router_options)
    calls: list[Call] = []
    open_connections = 0
    for net in board.net_names:
        pads = [p for p in board.pads if p.net == net]
        for a, b in zip(pads, pads[1:]):
            if not _connect(name, board, router, calls, a, b):
                open_connections += 1
    return board, calls, open_connections


def _connect(name, board, router, calls, a: Pad, b: Pad) -> bool:
    shared = [layer for layer in LAYERS if layer in pad_layers(a) and layer in pad_layers(b)]
    for layer in shared:
        path = _route(name, board, router, calls, a.net, layer, (a.x, a.y), (b.x, b.y))
        if path:
            _commit(board, router, a.net, layer, path)
            return True
    if shared:
        return False
    return _connect_with_via(name, board, router, calls, a, b)


def _connect_with_via(name, board, router, calls, a: Pad, b: Pad) -> bool:
    """A via on one of 8 spots around pad a, then a path on each side of it."""
    rules = board.rules
    reach = a.size / 2 + rules.via_diameter / 2 + rules.clearance
    for k in range(8):
        angle = k * math.pi / 4
        at = (a.x + round(reach * math.cos(angle)), a.y + round(reach * math.sin(angle)))
        if not router.via_fits(a.net, at, rules.via_diameter, rules.clearance, LAYERS):
            continue
        first = _route(name, board, router, calls, a.net, a.layer, (a.x, a.y), at)
        if not first:
            continue
        second = _route(name, board, router, calls, a.net, b.layer, at, (b.x, b.y))
        if not second:
            continue
        board.vias.append(
            Via(x=at[0], y=at[1], diameter=rules.via_diameter, drill=rules.via_drill, net=a.net)
        )
        _commit(board, router, a.net, a.layer, first)
        _commit(board, router, a.net, b.layer, second)
        return True
    return False


def _route(name, board, router, calls, net, layer, start, goal):
    request = RouteRequest(
        net=net,
        layer=layer,
        start=start,
        goal=goal,
        width=board.rules.track_width,
        clearance=board.rules.clearance,
    )
    began = time.perf_counter()
    result = router.route(request)
    seconds = time.perf_counter() - began
    calls.append(
        Call(
            name,
            net,
            seconds,
            result.stats.get("method", ""),
            result.path is not None,
            result.reason,
        )
    )
    return result.path


def _commit(board: Board, router: WalkaroundRouter, net: str, layer, path) -> None:
    for (x1, y1), (x2, y2) in zip(path, path[1:]):
        board.tracks.append(
            Track(x1=x1, y1=y1, x2=x2, y2=y2, width=board.rules.track_width, net=net, layer=layer)
        )
    router.update(geometry_from_board(board))


# --- the exact, independent legality check ----------------------------------------------------


def _pad_shape(pad: Pad) -> tuple[shapely.Geometry, float]:
    if pad.kind == "thru_round":
        return shapely.Point(pad.x, pad.y), pad.size / 2
    radius = pad.roundrect_ratio * pad.size if pad.kind == "smd_roundrect" else 0.0
    half = pad.size / 2 - radius
    core = shapely.box(pad.x - half, pad.y - half, pad.x + half, pad.y + half)
    return core, radius


def copper_shapes(board: Board) -> list[tuple[str, str, str, shapely.Geometry, float]]:
    """(what, net, layer, core, radius) for all copper; copper = core grown by radius."""
    out = []
    for i, pad in enumerate(board.pads):
        core, radius = _pad_shape(pad)
        out += [(f"pad {i}", pad.net, layer, core, radius) for layer in pad_layers(pad)]
    for i, t in enumerate(board.tracks):
        core = shapely.LineString([(t.x1, t.y1), (t.x2, t.y2)])
        out.append((f"track {i}", t.net, t.layer, core, t.width / 2))
    for i, v in enumerate(board.vias):
        out += [
            (f"via {i}", v.net, layer, shapely.Point(v.x, v.y), v.diameter / 2) for layer in LAYERS
        ]
    return out


def violations(board: Board) -> list[str]:
    """Clearance and edge violations that involve a track or via (pads are legal as generated)."""
    rules = board.rules
    shapes = copper_shapes(board)
    routed = [s for s in shapes if not s[0].startswith("pad")]
    out = []
    for what, net, layer, core, radius in routed:
        for other, onet, olayer, ocore, oradius in shapes:
            if olayer != layer or onet == net:
                continue
            gap = shapely.distance(core, ocore) - radius - oradius
            if gap < rules.clearance:
                out.append(f"{what} ({net}, {layer}) is {gap:.0f} nm from {other} ({onet})")
        outline = shapely.box(0, 0, board.width, board.height)
        if (
            not outline.contains(core)
            or shapely.distance(core, outline.exterior) - radius < rules.edge_clearance
        ):
            out.append(f"{what} ({net}, {layer}) is too close to the board edge")
    return sorted(set(out))

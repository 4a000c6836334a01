"""Plain-data copper geometry for the routing environment, and its exact shapes.

The environment reads the board out of KiCad into these records; the walkaround router
(`pcbdata.router.walkaround`) plans on them without importing KiCad. Units are integer
nanometres and layers are KiCad names ("F.Cu", "B.Cu", ...).

Every item becomes a *core* (a point, polyline or polygon) plus a *radius*: its copper is the
core buffered by the radius. Distances are then exact (`shapely.distance` minus radii) instead
of depending on how finely a buffer approximates round ends. Where an approximation cannot be
avoided (arcs, circles given as polygons) it errs outwards, so a path clear of the model is
clear of the real copper.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import shapely

Point = tuple[int, int]

# Polygons we draw for round shapes are circumscribed, i.e. they contain the true circle;
# 32 sides overstate a 2.4 mm pad by under 6 um, far below any clearance.
CIRCLE_SIDES = 32
CORNER_SIDES = 8
# An arc is modelled by chords plus this sagitta bound added to its half width.
ARC_MAX_SAGITTA = 5_000
ARC_MAX_CHORDS = 64


@dataclass(frozen=True)
class CopperItem:
    """One piece of copper on the board, plain data."""

    #: "pad" | "track" | "arc" | "via" | "zone" | "graphic" (copper drawing, text) | "hole" (a
    #: drilled hole, `start` its centre and `width` its diameter, kept the hole clearance from)
    kind: str
    net: str  # net name; "" = no net
    layers: tuple[str, ...]  # copper layers it occupies
    polygon: tuple[tuple[int, int], ...] = ()  # pads, zones: outline (nm), closed implicitly
    start: tuple[int, int] | None = None  # tracks/arcs: centreline ends; vias: centre
    end: tuple[int, int] | None = None
    mid: tuple[int, int] | None = None  # arcs only
    width: int = 0  # tracks/arcs: width; vias: diameter
    clearance: int = 0  # this item's net clearance (nm), from the rules

    def __hash__(self) -> int:
        """The hash a frozen dataclass gives (of its fields' tuple), worked out once per item:
        the planners look the same items up many times. Kept out of pickles (`__getstate__`):
        a string's hash differs from one process to the next."""
        try:
            return self.__dict__["_hash"]
        except KeyError:
            value = hash((self.kind, self.net, self.layers, self.polygon, self.start, self.end,
                          self.mid, self.width, self.clearance))
            object.__setattr__(self, "_hash", value)
            return value

    def __getstate__(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "_hash"}


@dataclass(frozen=True)
class BoardGeometry:
    outline: tuple[tuple[tuple[int, int], ...], ...]  # Edge.Cuts rings; first = board
    copper: tuple[CopperItem, ...]
    edge_clearance: int


def item_sort_key(item: CopperItem) -> tuple:
    """A total order on items, so that results never depend on the order they came in."""
    return (
        item.kind,
        item.net,
        item.layers,
        item.polygon,
        item.start or (),
        item.end or (),
        item.mid or (),
        item.width,
        item.clearance,
    )


def copper_core(item: CopperItem) -> tuple[shapely.Geometry, float]:
    """(core, radius) whose buffer contains the item's copper."""
    if item.kind in ("pad", "zone", "graphic"):
        if len(item.polygon) < 3:
            raise ValueError(f"{item.kind} of net {item.net!r} needs a polygon of >= 3 points")
        return shapely.make_valid(shapely.Polygon(item.polygon)), 0.0
    if item.kind in ("via", "hole"):
        return shapely.Point(_required(item, "start")), item.width / 2
    if item.kind == "track":
        return _segment(_required(item, "start"), _required(item, "end")), item.width / 2
    if item.kind == "arc":
        chords, sagitta = arc_polyline(
            _required(item, "start"), _required(item, "mid"), _required(item, "end")
        )
        return shapely.LineString(chords), item.width / 2 + sagitta
    raise ValueError(f"unknown copper kind {item.kind!r}")


def _required(item: CopperItem, name: str) -> tuple[int, int]:
    value = getattr(item, name)
    if value is None:
        raise ValueError(f"{item.kind} of net {item.net!r} needs `{name}`")
    return value


def _segment(a: Point, b: Point) -> shapely.Geometry:
    return shapely.Point(a) if tuple(a) == tuple(b) else shapely.LineString([a, b])


def arc_polyline(start: Point, mid: Point, end: Point) -> tuple[list[tuple[float, float]], float]:
    """Chords of the arc start-mid-end and the largest gap between chords and arc."""
    (x1, y1), (x2, y2), (x3, y3) = start, mid, end
    det = 2 * (x1 * (y2 - y3) + x2 * (y3 - y1) + x3 * (y1 - y2))
    if det == 0:  # collinear: KiCad draws a straight track
        return [start, end] if start != end else [start, start], 0.0
    s1, s2, s3 = x1 * x1 + y1 * y1, x2 * x2 + y2 * y2, x3 * x3 + y3 * y3
    cx = (s1 * (y2 - y3) + s2 * (y3 - y1) + s3 * (y1 - y2)) / det
    cy = (s1 * (x3 - x2) + s2 * (x1 - x3) + s3 * (x2 - x1)) / det
    radius = math.hypot(x1 - cx, y1 - cy)
    a1, a2, a3 = (math.atan2(y - cy, x - cx) for x, y in (start, mid, end))
    sweep = (a3 - a1) % (2 * math.pi)
    if (a2 - a1) % (2 * math.pi) > sweep:  # the arc runs clockwise through mid
        sweep -= 2 * math.pi
    step_max = 2 * math.acos(max(-1.0, 1 - ARC_MAX_SAGITTA / radius))
    chords = min(ARC_MAX_CHORDS, max(2, math.ceil(abs(sweep) / step_max)))
    step = sweep / chords
    points = (
        [start]
        + [
            (cx + radius * math.cos(a1 + k * step), cy + radius * math.sin(a1 + k * step))
            for k in range(1, chords)
        ]
        + [end]
    )
    return points, radius * (1 - math.cos(step / 2))


def circle_polygon(cx: int, cy: int, radius: float, sides: int = CIRCLE_SIDES) -> tuple[Point, ...]:
    """A polygon around the circle (edges tangent to it), vertices rounded outwards."""
    out_radius = radius / math.cos(math.pi / sides)
    return tuple(
        _round_away(
            cx,
            cy,
            cx + out_radius * math.cos(2 * math.pi * (k + 0.5) / sides),
            cy + out_radius * math.sin(2 * math.pi * (k + 0.5) / sides),
        )
        for k in range(sides)
    )


def roundrect_polygon(
    cx: int, cy: int, width: int, height: int, radius: float, corner_sides: int = CORNER_SIDES
) -> tuple[Point, ...]:
    """A rounded rectangle as a polygon whose corners circumscribe the true corner arcs."""
    if radius <= 0:
        hx, hy = width / 2, height / 2
        return tuple(
            _round_away(cx, cy, cx + sx * hx, cy + sy * hy)
            for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))
        )
    out_radius = radius / math.cos(math.pi / (4 * corner_sides))
    points = []
    for quadrant, (sx, sy) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1))):
        ox, oy = cx + sx * (width / 2 - radius), cy + sy * (height / 2 - radius)
        base = quadrant * math.pi / 2
        # Tangent points at the ends of the corner keep the straight sides exact.
        points.append((ox + radius * math.cos(base), oy + radius * math.sin(base)))
        for k in range(corner_sides):
            angle = base + (k + 0.5) * (math.pi / 2) / corner_sides
            points.append((ox + out_radius * math.cos(angle), oy + out_radius * math.sin(angle)))
        points.append(
            (ox + radius * math.cos(base + math.pi / 2), oy + radius * math.sin(base + math.pi / 2))
        )
    return tuple(dict.fromkeys(_round_away(cx, cy, x, y) for x, y in points))


def _round_away(cx: float, cy: float, x: float, y: float) -> Point:
    """Rounds a vertex away from the centre, so a rounded polygon still contains the shape."""
    rx = math.ceil(x) if x >= cx else math.floor(x)
    ry = math.ceil(y) if y >= cy else math.floor(y)
    return int(rx), int(ry)


def geometry_from_board(board) -> BoardGeometry:
    """`BoardGeometry` of a `pcbdata.model.board.Board` (generated D1/D2 boards, and their routes).

    Every item gets the board's one clearance; through-hole pads and vias span F.Cu and B.Cu.
    """
    clearance = board.rules.clearance
    copper = [_pad_item(pad, clearance) for pad in board.pads]
    copper += [
        CopperItem(
            "track",
            t.net,
            (t.layer,),
            start=(t.x1, t.y1),
            end=(t.x2, t.y2),
            width=t.width,
            clearance=clearance,
        )
        for t in board.tracks
    ]
    copper += [
        CopperItem(
            "arc",
            a.net,
            (a.layer,),
            start=(a.x1, a.y1),
            mid=(a.xm, a.ym),
            end=(a.x2, a.y2),
            width=a.width,
            clearance=clearance,
        )
        for a in board.arcs
    ]
    copper += [
        CopperItem(
            "via", v.net, ("F.Cu", "B.Cu"), start=(v.x, v.y), width=v.diameter, clearance=clearance
        )
        for v in board.vias
    ]
    outline = ((0, 0), (board.width, 0), (board.width, board.height), (0, board.height))
    return BoardGeometry(
        outline=(outline,), copper=tuple(copper), edge_clearance=board.rules.edge_clearance
    )


def _pad_item(pad, clearance: int) -> CopperItem:
    layers: tuple[str, ...]
    if pad.kind == "thru_round":
        polygon, layers = circle_polygon(pad.x, pad.y, pad.size / 2), ("F.Cu", "B.Cu")
    else:
        ratio = pad.roundrect_ratio if pad.kind == "smd_roundrect" else 0.0
        polygon = roundrect_polygon(pad.x, pad.y, pad.size, pad.size, ratio * pad.size)
        layers = (pad.layer,)
    return CopperItem("pad", pad.net, layers, polygon=polygon, clearance=clearance)


# --- octilinear paths -------------------------------------------------------------------


def is_octilinear(a: Point, b: Point) -> bool:
    dx, dy = b[0] - a[0], b[1] - a[1]
    return dx == 0 or dy == 0 or abs(dx) == abs(dy)


def octilinear_length(a: Point, b: Point) -> float:
    """Length of the shortest octilinear path from a to b (no obstacles)."""
    dx, dy = abs(b[0] - a[0]), abs(b[1] - a[1])
    return max(dx, dy) + (math.sqrt(2) - 1) * min(dx, dy)


def one_bend_paths(a: Point, b: Point) -> tuple[tuple[Point, ...], ...]:
    """The octilinear paths from a to b with at most one bend: straight-then-45 first.

    Both have the octilinear length; the bend is on integer nanometres, so every segment is
    exactly horizontal, vertical or at 45 degrees.
    """
    a, b = (int(a[0]), int(a[1])), (int(b[0]), int(b[1]))
    if is_octilinear(a, b):
        return ((a, b),)
    dx, dy = b[0] - a[0], b[1] - a[1]
    m = min(abs(dx), abs(dy))
    diag = (m if dx > 0 else -m, m if dy > 0 else -m)
    straight_first = (a, (b[0] - diag[0], b[1] - diag[1]), b)
    diagonal_first = (a, (a[0] + diag[0], a[1] + diag[1]), b)
    return straight_first, diagonal_first


def direction(a: Point, b: Point) -> tuple[int, int]:
    """The octilinear heading of segment a-b as a pair of signs."""
    return ((b[0] > a[0]) - (b[0] < a[0]), (b[1] > a[1]) - (b[1] < a[1]))


def simplify_path(points) -> tuple[Point, ...]:
    """Drops repeated points and merges consecutive segments with the same heading."""
    out: list[Point] = []
    for p in points:
        p = (int(p[0]), int(p[1]))
        if out and p == out[-1]:
            continue
        if len(out) >= 2 and direction(out[-2], out[-1]) == direction(out[-1], p):
            out[-1] = p
        else:
            out.append(p)
    return tuple(out)


def bends(path) -> int:
    return sum(
        1
        for i in range(1, len(path) - 1)
        if direction(path[i - 1], path[i]) != direction(path[i], path[i + 1])
    )

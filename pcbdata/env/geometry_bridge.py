"""The board as the walkaround router sees it (`pcbdata.router.geometry.BoardGeometry`): pad
polygons per layer, tracks, vias and zones from KiCad, each with its net's clearance (a pad:
its own clearance override where that is larger, which KiCad's DRC holds tracks to), and the
holes that copper of other nets must keep the board's hole clearance from (`_hole_item`)."""
from __future__ import annotations

import shapely

from pcbdata.env.types import StaticBoard


def _pad_items(static: StaticBoard, clearance: dict[str, int], CopperItem) -> list:
    items = []
    least = min(clearance.values(), default=0)  # no request keeps less from a pad
    for pad in static.pads:
        by_shape: dict[tuple, list[str]] = {}
        for layer, rings in sorted(pad.polygons.items()):
            for ring in rings:
                by_shape.setdefault(tuple(tuple(p) for p in ring), []).append(layer)
        own = max(clearance.get(pad.net, 0), pad.clearance)
        for ring, layers in by_shape.items():
            items.append(CopperItem(kind="pad", net=pad.net, layers=tuple(layers), polygon=ring,
                                    clearance=own))
        hole = _hole_item(static, pad, max(least, own), CopperItem)
        if hole is not None:
            items.append(hole)
    return items


def _hole_item(static: StaticBoard, pad, kept: int, CopperItem):
    """The pad's hole as an item of its net (a disc of the drill's diameter, the board's hole
    clearance as its clearance) on the layers where the pad's copper does not already keep
    other nets that far from the hole (KiCad's hole_clearance); None where it does on all.
    Other nets' copper keeps at least `kept` from the pad's copper (the router holds a request
    to the larger of its own clearance and the pad's), so a layer is covered where the pad's
    copper reaches `hole_clearance - kept` beyond the hole all round: a plated pad with a ring
    that wide needs no item, a mounting hole (NPTH: the bare hole) gets one on every layer."""
    if pad.drill <= 0 or static.hole_clearance <= 0:
        return None
    centre = shapely.Point(pad.x, pad.y)
    reach = pad.drill / 2 + static.hole_clearance - kept  # copper must reach this far
    layers = tuple(layer for layer in static.layers if not any(
        polygon.contains(centre) and polygon.exterior.distance(centre) >= reach
        for polygon in (shapely.Polygon(ring) for ring in pad.polygons.get(layer, ()))))
    if not layers:
        return None
    at = (pad.x, pad.y)
    return CopperItem(kind="hole", net=pad.net, layers=layers, start=at, end=at,
                      width=pad.drill, clearance=static.hole_clearance)


def _copper_item(record: dict, static: StaticBoard, clearance: dict[str, int], CopperItem):
    net = record["net"]
    if record["kind"] == "via":
        at = (record["x"], record["y"])
        return CopperItem(kind="via", net=net, layers=static.layers, start=at, end=at,
                          width=record["diameter"], clearance=clearance.get(net, 0))
    return CopperItem(kind=record["kind"], net=net, layers=(record["layer"],),
                      start=tuple(record["start"]), end=tuple(record["end"]),
                      mid=tuple(record["mid"]) if "mid" in record else None,
                      width=record["width"], clearance=clearance.get(net, 0))


def board_geometry(static: StaticBoard, copper: list[dict]):
    """BoardGeometry of the static board plus the current tracks and vias."""
    from pcbdata.router.geometry import BoardGeometry, CopperItem

    clearance = {net.name: net.clearance for net in static.nets}
    items = list(_static_items(static))
    items += [_copper_item(r, static, clearance, CopperItem) for r in copper]
    return BoardGeometry(outline=static.outline, copper=tuple(items),
                         edge_clearance=static.edge_clearance)


# The latest static board and its items: an episode asks for them after every copper change.
_last_static: tuple[StaticBoard | None, tuple] = (None, ())


def _static_items(static: StaticBoard) -> tuple:
    """Pads, zones and copper drawings of the static board as `CopperItem`s."""
    global _last_static
    if _last_static[0] is static:
        return _last_static[1]
    from pcbdata.router.geometry import CopperItem

    clearance = {net.name: net.clearance for net in static.nets}
    default = max([n.clearance for n in static.nets] or [0])
    items = _pad_items(static, clearance, CopperItem)
    items += [CopperItem(kind="zone", net=z["net"], layers=(z["layer"],),
                         polygon=tuple(tuple(p) for p in z["polygon"]),
                         clearance=clearance.get(z["net"], default)) for z in static.zones]
    items += [CopperItem(kind="graphic", net=g["net"], layers=(g["layer"],),
                         polygon=tuple(tuple(p) for p in g["polygon"]),
                         clearance=clearance.get(g["net"], 0)) for g in static.graphics]
    _last_static = (static, tuple(items))
    return _last_static[1]

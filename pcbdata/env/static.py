"""The instance's static board (`types.StaticBoard`) from the KiCad session's plain data."""
from __future__ import annotations

from pcbdata.env.types import NetRules, PadInfo, StaticBoard
from pcbdata.sets.configs import ConfigSpec


def _lattice(spec: ConfigSpec) -> tuple[int | None, int | None]:
    """D1: the lattice pitch g = 100/G mm and the pad-centre offset 0.75 g (nm)."""
    if spec.family != "d1" or not spec.grid:
        return None, None
    pitch = 100_000_000 // spec.grid
    return pitch, (3 * pitch) // 4


def static_board(board_id: str, raw: dict, spec: ConfigSpec) -> StaticBoard:
    layers = tuple(raw["layers"])
    index = {name: i for i, name in enumerate(layers)}
    pads = tuple(PadInfo(net=p["net"], x=p["x"], y=p["y"], size=tuple(p["size"]),
                         shape=p["shape"], layers=tuple(index[n] for n in p["layers"]),
                         drill=p["drill"], name=p["name"], polygons=p["polygons"],
                         clearance=p.get("clearance", 0))
                 for p in raw["pads"])
    with_pads = {p.net for p in pads if p.net}
    nets = tuple(NetRules(n["name"], n["clearance"], n["track_width"], n["via_diameter"],
                          n["via_drill"]) for n in raw["nets"] if n["name"] in with_pads)
    outline = tuple(tuple(tuple(pt) for pt in ring) for ring in raw["outline"])
    pitch, origin = _lattice(spec)
    return StaticBoard(board_id=board_id, layers=layers, outline=outline, nets=nets, pads=pads,
                       zones=tuple(raw["zones"]), graphics=tuple(raw["graphics"]),
                       net_count=raw["net_count"],
                       edge_clearance=raw["edge_clearance"], grid_pitch=pitch,
                       grid_origin=origin, hole_clearance=raw["hole_clearance"])

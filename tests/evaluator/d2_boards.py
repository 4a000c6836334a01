"""A real D2 instance (default level, test board 0) with two zones, and an honest routed board.

The instance is `D2Generator(D2Params()).generate(0, "test", 0)` (15 pads, nets NET1-NET6, D2's
rules: clearance 0.3, min track width 0.3) plus a keepout rule area on both copper layers
((50, 65)-(60, 75), no tracks or vias) and an unfilled NET1 copper zone on F.Cu.

The honest routed board routes NET1 (an arc on B.Cu), NET2, NET3 and NET6 (a via) and leaves
NET4 and NET5 open. KiCad finds, on purpose, one of each kind a smuggled rule could hide:
- clearance: a NET2 stub ends 0.1 mm from NET4's through-hole pad at (40.8, 43.8);
- track_width: NET3's track is 0.25 mm wide (the minimum is 0.3);
- items_not_allowed: NET6 crosses the keepout on B.Cu;
- track_dangling (a warning: strict count only): the end of the NET2 stub;
- 5 unconnected items (NET4: 1, NET5: 4).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from boards import write_board, write_instance

from pcbdata.generators.d2 import D2Generator, D2Params
from pcbdata.model.board import Arc, Track, Via, mm_to_nm

ZONES = """\t(zone
\t\t(net 0)
\t\t(net_name "")
\t\t(layers "F.Cu" "B.Cu")
\t\t(uuid "6d0b7a1e-0000-4000-8000-000000000001")
\t\t(name "keepout")
\t\t(hatch edge 0.5)
\t\t(connect_pads
\t\t\t(clearance 0)
\t\t)
\t\t(min_thickness 0.25)
\t\t(filled_areas_thickness no)
\t\t(keepout
\t\t\t(tracks not_allowed)
\t\t\t(vias not_allowed)
\t\t\t(pads allowed)
\t\t\t(copperpour not_allowed)
\t\t\t(footprints allowed)
\t\t)
\t\t(fill
\t\t\t(thermal_gap 0.5)
\t\t\t(thermal_bridge_width 0.5)
\t\t)
\t\t(polygon
\t\t\t(pts
\t\t\t\t(xy 50 65) (xy 60 65) (xy 60 75) (xy 50 75)
\t\t\t)
\t\t)
\t)
\t(zone
\t\t(net 1)
\t\t(net_name "NET1")
\t\t(layer "F.Cu")
\t\t(uuid "6d0b7a1e-0000-4000-8000-000000000002")
\t\t(hatch edge 0.5)
\t\t(priority 1)
\t\t(connect_pads
\t\t\t(clearance 0.5)
\t\t)
\t\t(min_thickness 0.25)
\t\t(filled_areas_thickness no)
\t\t(fill
\t\t\t(thermal_gap 0.5)
\t\t\t(thermal_bridge_width 0.5)
\t\t)
\t\t(polygon
\t\t\t(pts
\t\t\t\t(xy 95 5) (xy 105 5) (xy 105 12) (xy 95 12)
\t\t\t)
\t\t)
\t)
"""


def d2_board():
    return D2Generator(D2Params()).generate(0, "test", 0).board


def _with_zones(path: Path) -> Path:
    text = path.read_text(encoding="utf-8")
    end = text.rindex("\t(embedded_fonts no)")
    path.write_text(text[:end] + ZONES + text[end:], encoding="utf-8")
    return path


def _track(x1, y1, x2, y2, net, layer="F.Cu", width_mm=0.3) -> Track:
    return Track(mm_to_nm(x1), mm_to_nm(y1), mm_to_nm(x2), mm_to_nm(y2), mm_to_nm(width_mm),
                 net, layer)


def honest_routing(board):
    tracks = [_track(10.2, 36, 87.6, 40.2, "NET3", "B.Cu", width_mm=0.25),
              _track(61.8, 18.6, 46.2, 43.8, "NET2"), _track(46.2, 43.8, 30, 70.2, "NET2"),
              _track(46.2, 43.8, 42.25, 43.8, "NET2"),
              _track(12.6, 57.6, 12.6, 70, "NET6"), _track(12.6, 70, 78.6, 70, "NET6", "B.Cu"),
              _track(78.6, 70, 78.6, 103.2, "NET6", "B.Cu")]
    arcs = [Arc(mm_to_nm(89.4), mm_to_nm(17.4), mm_to_nm(92.842), mm_to_nm(43.61),
                mm_to_nm(100.2), mm_to_nm(69), mm_to_nm(0.3), "NET1", "B.Cu")]
    vias = [Via(mm_to_nm(12.6), mm_to_nm(70), board.rules.via_diameter, board.rules.via_drill,
                "NET6")]
    return replace(board, tracks=tracks, arcs=arcs, vias=vias)


def write_d2_instance(folder: Path) -> Path:
    write_instance(d2_board(), folder)
    _with_zones(folder / "board.kicad_pcb")
    return folder


def write_honest_board(path: Path) -> Path:
    return _with_zones(write_board(honest_routing(d2_board()), path))


def tangled_routing(board):
    """Every net's pads chained in order by straight F.Cu tracks, across everything: dozens of
    shorts, clearance and hole violations over many nets (KiCad's DRC threads report them in
    no fixed order)."""
    by_net: dict[str, list] = {}
    for pad in board.pads:
        by_net.setdefault(pad.net, []).append(pad)
    tracks = [Track(a.x, a.y, b.x, b.y, board.rules.track_width, net, "F.Cu")
              for net, pads in by_net.items() for a, b in zip(pads, pads[1:])]
    return replace(board, tracks=tracks)


def write_tangled_board(path: Path) -> Path:
    return _with_zones(write_board(tangled_routing(d2_board()), path))


def save_with_kicad(source: str, target: str) -> None:
    """In a KiCad worker: loads a board and saves it again, as a router built on pcbnew does
    (KiCad rewrites the whole file and writes a project next to it)."""
    import pcbnew

    if not pcbnew.SaveBoard(target, pcbnew.LoadBoard(source)):
        raise RuntimeError(f"KiCad could not save {target}")


def write_honest_board_with_other_uuids(path: Path) -> Path:
    return _with_zones(write_board(replace(honest_routing(d2_board()), uuid_seed="rewritten"),
                                   path))

"""Hand-made instances and routed boards for the evaluator tests (all sizes in mm).

The base instance: a 60 x 40 mm two-layer board with D2's rules (clearance and track width 0.3,
via 1.2 / 0.6) and two nets of two 2.4 mm SMD pads on F.Cu:
A: (10, 10) - (50, 10) and B: (10, 30) - (50, 30). Routing A and B with one straight
track each is DRC-clean: WL = 80 mm.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from pcbdata.model.board import Arc, Board, Pad, Rules, Track, Via, mm_to_nm
from pcbdata.model.kicad_writer import board_files, board_text

RULES = Rules(clearance=mm_to_nm(0.3), track_width=mm_to_nm(0.3), edge_clearance=mm_to_nm(0.3),
              via_diameter=mm_to_nm(1.2), via_drill=mm_to_nm(0.6))
W = RULES.track_width


def pad(x: float, y: float, net: str, layer: str = "F.Cu") -> Pad:
    return Pad(mm_to_nm(x), mm_to_nm(y), net, "smd_roundrect", mm_to_nm(2.4), layer=layer)


def track(x1, y1, x2, y2, net, layer="F.Cu") -> Track:
    return Track(mm_to_nm(x1), mm_to_nm(y1), mm_to_nm(x2), mm_to_nm(y2), W, net, layer)


def via(x, y, net) -> Via:
    return Via(mm_to_nm(x), mm_to_nm(y), RULES.via_diameter, RULES.via_drill, net)


def base_board(**changes) -> Board:
    board = Board(width=mm_to_nm(60), height=mm_to_nm(40), rules=RULES,
                  pads=[pad(10, 10, "A"), pad(50, 10, "A"), pad(10, 30, "B"), pad(50, 30, "B")],
                  uuid_seed="evaluator-test")
    return replace(board, **changes)


ROUTE_A = track(10, 10, 50, 10, "A")
ROUTE_B = track(10, 30, 50, 30, "B")


def routed(board: Board, tracks=(), arcs=(), vias=()) -> Board:
    return replace(board, tracks=list(tracks), arcs=list(arcs), vias=list(vias))


def semicircle_a() -> Arc:
    """Net A as one half circle from (10, 10) to (50, 10) through (30, 30): length 20 pi."""
    return Arc(mm_to_nm(10), mm_to_nm(10), mm_to_nm(30), mm_to_nm(30), mm_to_nm(50),
               mm_to_nm(10), W, "A")


def write_instance(board: Board, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in board_files(board).items():
        (folder / name).write_text(text, encoding="utf-8")
    return folder


def write_board(board: Board, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(board_text(board), encoding="utf-8")
    return path


def kicad_loads(path: str) -> bool:
    """In a KiCad worker: whether KiCad itself loads the file as a board (`pcbnew.LoadBoard`)."""
    from pcbdata.kicad.basics import pcbnew_module

    return pcbnew_module().LoadBoard(path) is not None

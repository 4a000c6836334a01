from __future__ import annotations

from dataclasses import dataclass, field

from pcbdata.board import Board, nm_to_mm

SPLITS = ("train", "validation", "test")

# Physical limits of generated boards, checked with the parameters (before anything is
# written). KiCad stores coordinates as signed 32-bit nanometres, so nothing can lie beyond
# +-2147.48 mm; boards and every length are kept to 1 m, well inside that range (and below the
# largest page KiCad offers, 1219 mm). Copper features, clearances and holes are at least
# 10 micrometres: finer than any PCB process, and far above the 1 nm resolution of the files.
MAX_LENGTH_MM = 1000.0
MIN_FEATURE_MM = 0.01
# KiCad 9 board-setup minimums that the written projects keep (the DRC of a generated board
# reports them; measured): annular ring of a pad or via, and hole to other-net copper.
KICAD_MIN_ANNULAR_MM = 0.1
KICAD_HOLE_CLEARANCE_MM = 0.25


def board_id(index: int) -> str:
    return f"board_{index:05d}"


@dataclass
class Instance:
    """One generated task: the bare board, and for some generators a reference routing."""

    board_id: str
    board: Board
    reference: Board | None = None
    # D1 only: per net, (start cell, target cell) as (i, j); the pad of cell (i, j) is centred
    # at ((i + 0.75) g, (j + 0.75) g).
    cells: list[tuple[tuple[int, int], tuple[int, int]]] = field(default_factory=list)

    def facts(self, routing_layers: int) -> dict:
        board = self.board
        return {
            "n_nets": len(board.net_names),
            "n_pads": board.n_pads,
            "n_components": len(board.pads),  # a generated board has one footprint per pad
            "n_layers": 2,
            "routing_layers": routing_layers,
            "width_mm": nm_to_mm(board.width),
            "height_mm": nm_to_mm(board.height),
        }

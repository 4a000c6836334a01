from __future__ import annotations

from dataclasses import dataclass, field

from pcbdata.board import Board, nm_to_mm

SPLITS = ("train", "validation", "test")


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

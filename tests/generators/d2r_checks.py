"""Checks shared by the D2R generator tests: placement every board must pass, packed or not,
and the bytes a level's parameters wrote before a generator change."""
from __future__ import annotations

from shapely.geometry import Polygon, box

from pcbdata.core.hashing import sha256_text
from pcbdata.core.tree import BOARD_FILE
from pcbdata.generators.d2r.generator import pad_position
from pcbdata.model.board import Board, EdgeArc, Part
from pcbdata.model.kicad_writer import board_files
from pcbdata.sets.configs import level_config


def courtyard(part: Part) -> Polygon:
    """The part's courtyard rectangle, worked out here (not by the generator's own helper)."""
    half_w, half_h = part.courtyard if part.rotation % 180 == 0 else part.courtyard[::-1]
    return box(part.x - half_w, part.y - half_h, part.x + half_w, part.y + half_h)


def outline(board: Board) -> Polygon:
    """The outline as a polygon; arcs become chords, which lie inside the true outline, so a
    shape inside this polygon is inside the board."""
    if not board.outline:
        return box(0, 0, board.width, board.height)
    points = []
    for edge in board.outline:
        points.append((edge.x1, edge.y1))
        if isinstance(edge, EdgeArc):
            points.append((edge.xm, edge.ym))
    return Polygon(points)


def assert_courtyards_apart(boards: list[Board]) -> None:
    """No two courtyards overlap on one side (a through-hole part occupies both)."""
    for board in boards:
        for side in ("F", "B"):
            rects = [courtyard(p).bounds for p in board.parts if p.side == side or p.through_hole]
            for i, a in enumerate(rects):
                for b in rects[:i]:
                    apart = a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
                    assert apart, (board.uuid_seed, side, a, b)


def assert_inside_outline(boards: list[Board]) -> None:
    """Every courtyard and pad lies inside the outline, the edge clearance away."""
    for board in boards:
        inner = outline(board).buffer(-board.rules.edge_clearance, join_style=2)
        assert inner.is_valid and inner.area > 0
        for part in board.parts:
            assert inner.covers(courtyard(part)), (board.uuid_seed, part.ref)
            for pad in part.pads:
                x, y = pad_position(part, pad)
                assert inner.contains(box(x - 1, y - 1, x + 1, y + 1))


def assert_train_boards_unchanged(overrides: dict, sha256_by_index: dict[int, str]) -> None:
    """Level a with `overrides` still writes these train boards (seed 0) byte for byte: a new
    parameter at its off value draws no number."""
    generator = level_config("d2r", "a", overrides).generator()
    for index, sha in sha256_by_index.items():
        board = generator.generate(0, "train", index).board
        assert sha256_text(board_files(board)[BOARD_FILE]) == sha, index

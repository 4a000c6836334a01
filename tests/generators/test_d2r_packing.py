"""D2R packed boards (`packed_fraction`): parts packed together and the outline cut around
them. Courtyards stay disjoint and inside the outline, every shape and the mounting holes still
occur, small packed boards reach the density of real breakout boards that random placement
does not, and with packing off the boards are byte for byte what they were."""
from __future__ import annotations

import statistics

import pytest

from pcbdata.core.rng import Stream
from pcbdata.generators.d2r import footprints as fp
from pcbdata.generators.d2r.layout import Packer, footprint_box
from pcbdata.model.board import Board, EdgeArc, Part
from pcbdata.model.kicad_writer import board_files
from pcbdata.sets.configs import level_config
from tests.generators.d2r_checks import (
    assert_courtyards_apart,
    assert_inside_outline,
    assert_train_boards_unchanged,
    outline,
)

PACKED = {"packed_fraction": 1.0}
# Every outline shape, mounting holes on every board and a crowded back side, all packed.
PACKED_SHAPES = {**PACKED, "mounting_hole_fraction": 1.0, "back_side_fraction": 0.8,
                 "outline_mix": {"rect": 0.2, "rounded": 0.2, "chamfered": 0.2, "l_shape": 0.2,
                                 "notch": 0.2}}
CM2 = 1e14  # nm^2


def _boards(level: str, count: int, overrides: dict | None = None) -> list[Board]:
    generator = level_config("d2r", level, overrides).generator()
    return [generator.generate(0, "test", i).board for i in range(count)]


@pytest.fixture(scope="module")
def packed() -> list[Board]:
    return _boards("a", 40, PACKED) + _boards("a", 40, PACKED_SHAPES) + _boards(
        "b", 10, PACKED_SHAPES)


def _courtyard(part: Part) -> tuple[int, int, int, int]:
    return footprint_box(part.x, part.y, part.courtyard, part.rotation)


def _density(board: Board) -> float:
    """Terminal pads per cm² of the outline."""
    return board.n_pads / (outline(board).area / CM2)


def test_packed_courtyards_never_overlap_on_one_side(packed):
    assert_courtyards_apart(packed)


def test_packed_courtyards_and_pads_lie_inside_the_outline_with_edge_clearance(packed):
    assert_inside_outline(packed)


def test_the_outline_is_cut_around_the_parts(packed):
    """Every side of a packed board without mounting holes is at most the largest margin
    (`packed_margin_mm`, 2 mm by default) plus a step of the outline grid from a courtyard."""
    margin = 2_000_000 + 100_000
    plain = [b for b in packed if not any(p.name.startswith("MountingHole") for p in b.parts)]
    assert len(plain) >= 30
    for board in plain:
        boxes = [_courtyard(p) for p in board.parts]
        assert min(b[0] for b in boxes) <= margin and min(b[1] for b in boxes) <= margin
        assert board.width - max(b[2] for b in boxes) <= margin
        assert board.height - max(b[3] for b in boxes) <= margin


def test_packed_boards_keep_rotations_sides_shapes_and_mounting_holes(packed):
    parts = [p for b in packed for p in b.parts]
    assert {p.rotation for p in parts} == {0, 90, 180, 270}
    assert {p.side for p in parts} == {"F", "B"}
    shaped = packed[40:]
    assert all(sum(p.name.startswith("MountingHole") for p in b.parts) == 4 for b in shaped)
    arcs = sum(any(isinstance(e, EdgeArc) for e in b.outline) for b in shaped)
    polygons = sum(bool(b.outline) and not any(isinstance(e, EdgeArc) for e in b.outline)
                   for b in shaped)  # chamfers, L-shapes and notches
    assert arcs >= 3 and polygons >= 5


def _cover(board: Board) -> float:
    """The busier side's share of the outline covered by courtyards (a through-hole part
    covers both sides)."""
    load = {"F": 0, "B": 0}
    for part in board.parts:
        for side in ("F", "B") if part.through_hole else (part.side,):
            load[side] += 4 * part.courtyard[0] * part.courtyard[1]
    return max(load.values()) / outline(board).area


def test_small_packed_boards_reach_the_density_of_real_breakout_boards():
    """Real D3-A's densest boards are breakouts of 2-5 parts at 12-18 terminal pads per cm²,
    cut around their parts. Random spots on a board sized beforehand, even at the fill's top
    (the busier side's courtyards twice the board), cover less than half of it; packed boards
    two thirds, and reach those densities (how far depends on the parts: a through-hole part
    takes both sides, an 0603 holds six times the pads per area of a DIP)."""
    small = {"components_median": 3.0, "components_sigma": 0.3, "fill_style_coupling": 0.0,
             "mounting_hole_fraction": 0.0}
    packed = _boards("a", 60, {**small, **PACKED, "packed_margin_mm": [0.5, 1.0]})
    placed = _boards("a", 60, {**small, "fill_range": [1.9, 2.0]})
    cover = [statistics.median(_cover(b) for b in boards) for boards in (packed, placed)]
    assert cover[0] >= 0.6 and cover[0] >= 1.3 * cover[1]
    density = [[_density(b) for b in boards] for boards in (packed, placed)]
    assert max(density[0]) >= 12 and max(density[0]) > max(density[1]) + 2
    assert sum(d >= 10 for d in density[0]) >= 2 * sum(d >= 10 for d in density[1])


def test_packing_draws_the_same_parts_on_the_same_sides():
    """Packing changes where parts go and the outline, nothing drawn before."""
    def parts(overrides: dict) -> list[list[tuple[str, str]]]:
        return [sorted((p.name, p.side) for p in b.parts if not p.name.startswith("Mounting"))
                for b in _boards("a", 20, overrides)]

    assert parts(PACKED) == parts({"packed_fraction": 0.0})


def test_packed_boards_are_deterministic():
    first, second = (level_config("d2r", "a", PACKED_SHAPES).generator() for _ in range(2))
    for index in range(3):
        assert board_files(first.generate(5, "train", index).board) == board_files(
            second.generate(5, "train", index).board)


# Level a 4.0.0's parameters as `551c190` fitted them, before packing, and three of its train
# boards' sha256 as that commit wrote them: with packing off, the same parameters still give
# the same bytes (no number is drawn for it).
LEVEL_A_4_0_0 = {
    "fill_range": [0.07, 2.0], "fill_style_coupling": 0.7, "packed_fraction": 0.0,
    "components_median": 4.8, "components_sigma": 0.8, "pads_per_component_median": 3.8,
    "pads_per_component_sigma": 0.55, "pads_range": [13, 29], "top_up_by_pins": 1.0,
    "part_mix": {"passive": 0.18, "axial": 0.20, "radial": 0.17, "sot23": 0.05, "soic": 0.05,
                 "tssop": 0.0, "dip": 0.08, "qfn": 0.0, "qfp": 0.0, "header": 0.17,
                 "connector": 0.10}}
LEVEL_A_4_0_0_BOARDS = {
    0: "772f78cdbd7c01e101abc4c4f49d62e83d5e4d5f471fedda1af43bbed50411cc",
    1: "aa8918c25ed41f0e99975de660e8478e9eb81ca913b75c4ce1f8045f354fcb07",
    2: "59d4fc81865ed264d0d877e18209541c42512cad0095d0b4d101bac8f10da549"}


def test_with_packing_off_boards_are_byte_identical_to_before():
    assert_train_boards_unchanged(LEVEL_A_4_0_0, LEVEL_A_4_0_0_BOARDS)


def test_the_packer_puts_each_part_against_the_others():
    """Four equal headers end up as one block, not a row or scattered: their bounding box is
    no larger than a 2 x 2 arrangement with the gaps."""
    packer = Packer(gap=100_000, grid=50_000, margin=1_000_000, aspect=1.8)
    header = fp.pin_header(1, 4)
    stream = Stream(0, 3, 0, "test", 0)
    parts = [packer.place(stream, header, "F", f"J{i}") for i in range(4)]
    boxes = [_courtyard(p) for p in parts]
    width = max(b[2] for b in boxes) - min(b[0] for b in boxes)
    height = max(b[3] for b in boxes) - min(b[1] for b in boxes)
    long_side, short_side = 2 * max(header.courtyard), 2 * min(header.courtyard)
    assert width * height <= (long_side + 200_000) * (4 * short_side + 400_000)
    assert max(width, height) <= 1.8 * min(width, height) + 1


def test_the_packer_stacks_smd_parts_of_the_two_sides():
    """A back-side SMD part may sit right under a front-side one: the packed block holds both
    in the footprint of one."""
    packer = Packer(gap=100_000, grid=50_000, margin=1_000_000, aspect=1.8)
    stream = Stream(0, 3, 0, "test", 0)
    part = fp.qfn(4, 0.5, True)  # a square courtyard: every rotation covers the same
    front = packer.place(stream, part, "F", "U1")
    back = packer.place(stream, part, "B", "U2")
    assert back.side == "B" and _courtyard(front) == _courtyard(back)


@pytest.mark.parametrize("overrides, message", [
    ({"packed_fraction": 1.5}, "packed_fraction must be in [0, 1]"),
    ({"packed_margin_mm": [2.0, 1.0]}, "packed_margin_mm must be [low, high]"),
])
def test_bad_packing_parameters_are_rejected(overrides, message):
    from pcbdata.core.errors import UserError
    with pytest.raises(UserError, match=message.replace("[", r"\[")):
        level_config("d2r", "a", overrides)


def test_packed_boards_pass_kicads_drc_but_for_unconnected_items(kicad_pool, tmp_path):
    from pcbdata.kicad import DrcReport
    from pcbdata.testing.sets import write_board

    boards = _boards("a", 4, PACKED_SHAPES) + _boards("a", 4, {**PACKED, "back_side_fraction": 1.0})
    jobs = [(str(write_board(tmp_path / str(i), b)), b.missing_connections)
            for i, b in enumerate(boards)]
    for outcome in kicad_pool.map("pcbdata.kicad.basics:drc", [(p,) for p, _ in jobs]):
        assert outcome.ok, outcome.error
        report = DrcReport.from_dict(outcome.value)
        assert report.counts_by_type() == {"unconnected_items": jobs[outcome.index][1]}

"""D2R (SPEC section 2b): determinism, geometry (courtyards, outline, edge clearance), nets and
net classes, parameter checks, and KiCad's DRC on boards of every level."""
from __future__ import annotations

import json
import math
import statistics

import pytest

from pcbdata.core.errors import UserError
from pcbdata.core.rng import Stream
from pcbdata.core.tree import PROJECT_FILE, RULES_FILE
from pcbdata.generators.d2r import footprints as fp
from pcbdata.generators.d2r.generator import D2RGenerator, D2RParams, _Draws, pad_position
from pcbdata.kicad import DrcReport
from pcbdata.model.board import Board, EdgeArc
from pcbdata.model.kicad_writer import board_files
from pcbdata.sets.configs import level_config
from pcbdata.sets.presets import level as preset_level
from pcbdata.sets.presets import levels as preset_levels
from pcbdata.testing.sets import write_board
from tests.generators.d2r_checks import assert_courtyards_apart, assert_inside_outline

LEVELS = sorted(preset_levels("d2r"))
# Every outline shape, mounting holes, four layers and a crowded back side on one level.
SHAPES = {"outline_mix": {"rounded": 0.25, "chamfered": 0.25, "l_shape": 0.25, "notch": 0.25},
          "mounting_hole_fraction": 1.0, "four_layer_fraction": 0.5, "back_side_fraction": 0.8}


# Boards that would have more ratsnest edges than KiCad's DRC report lists (499).
HUGE = {"components_median": 300.0, "components_sigma": 0.0, "pads_per_component_sigma": 0.0}


def test_no_board_has_more_missing_connections_than_kicads_drc_can_report():
    assert [b.missing_connections for b in _boards("c", 2, HUGE)] == [499, 499]
    with pytest.raises(UserError, match="max_connections must be from 1 to 499"):
        level_config("d2r", "c", {"max_connections": 500})


def test_parts_that_never_fit_are_a_generation_error_not_a_giant_board():
    from pcbdata.core.errors import GenerationError

    generator = level_config("d2r", "a", {"courtyard_gap_mm": 200.0}).generator()
    with pytest.raises(GenerationError, match="could not place"):
        generator.generate(0, "test", 0)


def _boards(level: str, count: int, overrides: dict | None = None) -> list[Board]:
    generator = level_config("d2r", level, overrides).generator()
    return [generator.generate(0, "test", i).board for i in range(count)]


@pytest.fixture(scope="module")
def boards() -> list[Board]:
    out = [b for level in LEVELS for b in _boards(level, 40)]
    return out + _boards("b", 60, SHAPES)


def test_same_seed_split_and_index_give_the_same_bytes():
    params = preset_level("d2r", "b").params
    first, second = D2RGenerator(params), D2RGenerator(params)
    for index in range(3):
        a = board_files(first.generate(7, "validation", index).board)
        assert a == board_files(second.generate(7, "validation", index).board)
    assert board_files(first.generate(7, "validation", 0).board) != board_files(
        first.generate(7, "validation", 1).board)
    assert board_files(first.generate(7, "validation", 0).board) != board_files(
        first.generate(8, "validation", 0).board)


def test_courtyards_never_overlap_on_one_side(boards):
    assert_courtyards_apart(boards)


def test_every_courtyard_and_pad_lies_inside_the_outline_with_edge_clearance(boards):
    assert_inside_outline(boards)


def test_rotations_sides_shapes_and_layers_all_occur(boards):
    parts = [p for b in boards for p in b.parts]
    assert {p.rotation for p in parts} == {0, 90, 180, 270}
    assert {p.side for p in parts} == {"F", "B"}
    assert all(not p.through_hole for p in parts if p.side == "B")
    assert {b.copper_layers for b in boards} == {2, 4}
    arcs = sum(isinstance(e, EdgeArc) for b in boards for e in b.outline)
    assert arcs > 0 and any(not b.outline for b in boards)
    names = {p.name.split("_")[0].split("-")[0] for p in parts}
    assert {"RC", "SOIC", "QFN", "PinHeader", "MountingHole", "Axial", "DIP"} <= names


def test_power_nets_have_many_pads_signal_nets_are_local_and_some_pins_are_free(boards):
    near, spread, free, ground_largest = [], [], 0, 0
    for board in boards:
        pads = [(pad.net, pad_position(part, pad)) for part in board.parts for pad in part.pads
                if pad.plated]
        free += any(not net for net, _ in pads)
        sizes = {net: sum(n == net for n, _ in pads) for net in board.net_names}
        assert all(size >= 2 for size in sizes.values())
        assert set(board.net_classes[0].nets) <= set(sizes) - {n for n in sizes if n[0] == "N"}
        ground_largest += sizes.get("GND", 0) == max(sizes.values())
        for net in board.net_names:
            if net.startswith("N"):
                xy = [p for n, p in pads if n == net]
                near.append(math.dist(xy[0], xy[1]))
        where = [xy for net, xy in pads if net]
        spread += [math.dist(a, b) for a, b in zip(where, where[7:])]
    assert free > 0.9 * len(boards)  # unconnected pins
    assert ground_largest > 0.8 * len(boards)  # ground touches the most pads
    # Signal nets join nearby parts: their pins are far closer than pins in general.
    assert statistics.median(near) < 0.6 * statistics.median(spread)


def test_net_classes_are_written_to_the_project_and_the_custom_rules():
    board = _boards("b", 1)[0]
    files = board_files(board)
    project = json.loads(files[PROJECT_FILE])["net_settings"]
    power = next(c for c in project["classes"] if c["name"] == "Power")
    params = D2RParams()
    assert power["clearance"] == params.power_clearance_mm
    assert power["track_width"] == params.power_track_width_mm
    patterns = {p["pattern"]: p["netclass"] for p in project["netclass_patterns"]}
    assert patterns["GND"] == "Power" and not any(n.startswith("N") for n in patterns)
    rules = files[RULES_FILE]
    assert "(condition \"A.NetClass == 'Power'\")" in rules
    assert f"(constraint track_width (min {params.power_track_width_mm:g}mm))" in rules
    assert f"(constraint clearance (min {params.power_clearance_mm:g}mm))" in rules
    assert f"(constraint via_diameter (min {params.power_via_diameter_mm:g}mm))" in rules


def test_levels_follow_their_tier_sizes():
    """The medians of components and terminal pads are near the levels' targets."""
    for level, components, pads in (("a", 7, 17), ("b", 19, 57), ("c", 55, 180)):
        sample = _boards(level, 40)
        assert abs(statistics.median(len(b.parts) for b in sample) / components - 1) < 0.35
        assert abs(statistics.median(b.n_pads for b in sample) / pads - 1) < 0.35


def test_radial_parts_take_the_levels_pitches():
    sample = _boards("b", 30, {"part_mix": {"radial": 0.5, "header": 0.5},
                               "radial_pitches_mm": [3.5]})
    names = {part.name for board in sample for part in board.parts if part.name.startswith("Rad")}
    assert names == {"Radial_P3.5"}


def test_passives_from_a_library_take_its_land_patterns():
    """With `land_pattern_library` every board off the nominal land patterns takes one
    published library distance per size (`PASSIVE_LIBRARY_PITCHES_MM`), no value between."""
    sample = _boards("b", 30, {"land_pattern_spread": 1.0, "land_pattern_library": 1.0,
                               "part_mix": {"passive": 0.8, "header": 0.2}})
    allowed = {f"RC_{size}_P{v:g}" for size, values in fp.PASSIVE_LIBRARY_PITCHES_MM.items()
               for v in values}
    names = {p.name for board in sample for p in board.parts if p.name.startswith("RC_")}
    assert names <= allowed and len(names) >= 8


@pytest.mark.parametrize("sign", [1, -1])
def test_joint_correlation_draws_a_boards_choices_together(sign):
    """A board's draws follow `joint_correlation`: with part count and layer count correlated,
    four-layer boards have more parts than two-layer ones (fewer at a negative correlation);
    each draw keeps its own distribution (about `four_layer_fraction` of the boards)."""
    sample = _boards("a", 80, {"four_layer_fraction": 0.5, "components_range": [2, 60],
                               "joint_correlation": {"components:layers": sign * 0.9}})
    four = [len(b.parts) for b in sample if b.copper_layers == 4]
    two = [len(b.parts) for b in sample if b.copper_layers == 2]
    assert 25 <= len(four) <= 55
    assert sign * (statistics.median(four) - statistics.median(two)) >= 3


def _smd_share_and_density(board: Board) -> tuple[float, float]:
    parts = [p for p in board.parts if p.pads and p.pads[0].plated]
    smd = sum(1 for p in parts if not any(pad.drill for pad in p.pads)) / len(parts)
    return smd, board.n_pads / (board.width * board.height)


def test_fill_style_coupling_makes_smd_boards_the_dense_ones():
    """Dense real boards are SMD boards: with the coupling, a board's SMD share and its pad
    density rise together; without it they hardly do."""
    def correlation(coupling: float) -> float:
        pairs = [_smd_share_and_density(b) for b in _boards(
            "b", 40, {"fill_style_coupling": coupling, "fill_range": [0.1, 2.0]})]
        return statistics.correlation([p[0] for p in pairs], [p[1] for p in pairs])

    coupled, free = correlation(1.0), correlation(0.0)
    assert coupled > 0.5 and coupled > free + 0.2


def test_pad_targets_outside_the_range_are_drawn_again_not_piled_at_its_ends():
    """Clipping a lognormal target to a narrow range piles a third of the boards on its two
    ends; drawing again spreads them over the range, as real tiers are."""
    generator = level_config("d2r", "a", {"pads_range": [15, 25],
                                 "pads_per_component_sigma": 0.5}).generator()
    targets = [generator._pad_target(_Draws(Stream(0, 3, 0, "test", i), None), 6)
               for i in range(400)]
    assert 15 <= min(targets) and max(targets) <= 25
    at_ends = sum(t in (15, 25) for t in targets) / len(targets)
    assert at_ends < 0.2


def test_a_style_spread_above_one_makes_boards_of_one_style_only():
    def pure(spread: float) -> int:
        mixed = {"passive": 0.5, "axial": 0.5}
        kinds = [{p.name.split("_")[0] for p in board.parts}
                 for board in _boards("a", 40, {"style_spread": spread, "part_mix": mixed})]
        return sum(len(k) == 1 for k in kinds)

    assert pure(2.0) > 10 and pure(2.0) > pure(1.0) + 5


def _net_sizes(board: Board) -> dict[str, int]:
    sizes: dict[str, int] = {}
    for part in board.parts:
        for pad in part.pads:
            if pad.net:
                sizes[pad.net] = sizes.get(pad.net, 0) + 1
    return sizes


def _spread(values: list[float]) -> float:
    """The 10-90 % range of a per-board share."""
    deciles = statistics.quantiles(values, n=10)
    return deciles[-1] - deciles[0]


def test_a_net_size_spread_gives_boards_of_two_pad_nets_and_boards_of_larger_ones():
    """Real boards differ in their nets: some are nearly all two-pad nets, others mostly
    larger ones (D3-B: 11-94 % two-pad nets, 5-95 %); one size table for all boards gave
    38-77 %."""
    def two_pad_shares(spread: float) -> list[float]:
        shares = []
        for board in _boards("b", 80, {"net_size_spread": spread}):
            sizes = list(_net_sizes(board).values())
            shares.append(sum(n == 2 for n in sizes) / len(sizes))
        return shares

    assert _spread(two_pad_shares(1.0)) > _spread(two_pad_shares(0.0)) + 0.1


# Level b 4.0.0's part draws (the parameter defaults), which level b 5.0.0 changes.
LEVEL_B_4_PARTS = {"pads_per_component_sigma": 0.15, "top_up_by_pins": 0.0,
                   "land_pattern_spread": 0.0, "package_variety": 0.0, "style_spread": 1.0,
                   "joint_correlation": {}}


def test_a_power_spread_gives_boards_of_small_and_large_power_nets():
    """The share of a board's terminal pads on its largest net (ground, mostly): D3-B 9-40 %
    (5-95 %), level b 4.0.0 13-31 % (measured on its parts: level b 5.0.0's wider pads per
    part spread the share by themselves)."""
    def largest_shares(spread: float) -> list[float]:
        shares = []
        for board in _boards("b", 120, {"power_spread": spread, "decoupling_fraction": 0.8,
                                        **LEVEL_B_4_PARTS}):
            sizes = _net_sizes(board)
            shares.append(max(sizes.values()) / sum(sizes.values()))
        return shares

    assert _spread(largest_shares(1.0)) > _spread(largest_shares(0.0)) + 0.04


@pytest.mark.parametrize("overrides, message", [
    ({"components_medain": 5}, "did you mean 'components_median'"),
    ({"part_mix": {"passive": 0.5, "qfn": 0.2}}, "part_mix probabilities must sum to 1"),
    ({"part_mix": {"passive": 0.5, "bga": 0.5}}, "unknown key 'bga'"),
    ({"qfn_pitches_mm": [0.3]}, "qfn_pitches_mm must list pitches"),
    ({"radial_pitches_mm": [1.0]}, "radial_pitches_mm must list pitches from 2 to 10 mm"),
    ({"fill_style_coupling": 1.5}, "fill_style_coupling must be in [0, 1]"),
    ({"style_spread": 2.5}, "style_spread must be from 0 to 2"),
    ({"top_up_by_pins": 1.5}, "top_up_by_pins must be in [0, 1]"),
    ({"net_size_spread": 2.5}, "net_size_spread must be from 0 to 2"),
    ({"power_spread": -0.1}, "power_spread must be from 0 to 1"),
    ({"power_clearance_mm": 0.25}, "above the library's smallest gap"),
    ({"via_drill_mm": 0.8, "via_diameter_mm": 1.2, "power_via_drill_mm": 0.8,
      "power_via_diameter_mm": 1.2}, "above the library's smallest pad hole"),
    ({"power_track_width_mm": 0.1}, "power_track_width_mm must not be below"),
    ({"via_diameter_mm": 0.4}, "annular ring"),
    ({"components_range": [5, 2]}, "components_range must be"),
    ({"fill_range": 0.5}, "must be a range [low, high]"),
    ({"components_median": "many"}, "must be a number"),
    ({"locality": 2.5}, "must be an integer"),
    ({"joint_correlation": {"fill:colour": 0.3}}, "keys are two different draws 'a:b'"),
    ({"joint_correlation": {"fill:fill": 0.3}}, "keys are two different draws 'a:b'"),
    ({"joint_correlation": {"fill:power": 1.0}}, "fill:power must lie strictly between -1 and 1"),
    ({"joint_correlation": {"fill:power": 0.3, "power:fill": 0.2}},
     "'fill:power' and 'power:fill' name the same pair"),
    ({"joint_correlation": ["fill:power"]}, "must be a table {key = number, ...}"),
    ({"joint_correlation": {"fill:power": 0.9, "fill:style": 0.9, "power:style": -0.9}},
     "do not fit together"),
    ({"land_pattern_library": 1.5}, "land_pattern_library must be in [0, 1]"),
])
def test_bad_parameters_are_rejected_with_the_reason(overrides, message):
    with pytest.raises(UserError, match=message.replace("[", r"\[").replace("(", r"\(")):
        level_config("d2r", "b", overrides)


def test_every_level_and_shape_passes_kicads_drc_but_for_unconnected_items(kicad_pool,
                                                                             tmp_path):
    jobs = []
    samples = [(level, None, 2) for level in LEVELS] + [("a", SHAPES, 4), ("c", HUGE, 1)]
    for level, overrides, count in samples:
        for index, board in enumerate(_boards(level, count, overrides)):
            path = write_board(tmp_path / f"{level}-{overrides is not None}-{index}", board)
            jobs.append((str(path), board.missing_connections))
    for outcome in kicad_pool.map("pcbdata.kicad.basics:drc", [(p,) for p, _ in jobs]):
        assert outcome.ok, outcome.error
        report = DrcReport.from_dict(outcome.value)
        assert report.counts_by_type() == {"unconnected_items": jobs[outcome.index][1]}

"""D2R parts (`pcbdata.generators.d2r.parts`): parts drawn by pin count have the pins asked for,
the top-up by pin count reaches the pins a board's pad target needs, and with it off a level's
boards stay byte for byte what they were."""
from __future__ import annotations

import functools

import pytest

from pcbdata.core.rng import Stream
from pcbdata.generators.d2r import D2RParams
from pcbdata.generators.d2r import footprints as fp
from pcbdata.generators.d2r.parts import (
    DIP_PINS,
    LARGEST_PINS,
    PartDrawer,
    Style,
    joinable_pins,
    pins,
    pins_to_ask,
)
from pcbdata.sets.configs import level_config
from pcbdata.sets.presets import level
from tests.generators.d2r_checks import assert_train_boards_unchanged

PASSIVES = {"0603": 1.0}


@functools.cache
def _drawer() -> PartDrawer:
    return PartDrawer(level("d2r", "a").params)


def _by_pins(mix: dict[str, float], wanted: int, index: int = 0) -> fp.Template:
    stream = Stream(0, 3, 0, "test", index)
    return _drawer().by_pins(stream, Style(mix, PASSIVES), wanted)


@pytest.mark.parametrize("kind", ["header", "connector", "dip", "soic", "tssop", "qfn", "qfp"])
def test_a_part_drawn_by_pin_count_has_the_pins_asked_for_or_its_kinds_most(kind):
    for wanted in range(1, 70):
        for index in range(4):
            template = _by_pins({kind: 1.0}, wanted, index)
            assert template.kind == kind
            assert pins(template) >= min(wanted, LARGEST_PINS[kind]), (kind, wanted)


def test_a_part_drawn_by_pin_count_is_its_kinds_smallest_with_those_pins():
    for wanted in range(1, 40):
        dip = pins(_by_pins({"dip": 1.0}, wanted))
        assert dip == next((n for n in DIP_PINS if n >= wanted), max(DIP_PINS))
        header = _by_pins({"header": 1.0}, wanted)
        rows = 2 if "_2x" in header.name else 1
        assert pins(header) - rows < max(wanted, 2), (wanted, header.name)


def test_only_kinds_that_come_that_large_are_drawn_by_pin_count():
    """A board needing 12 more pins gets a header or DIP, never one more two-pin part; one
    needing 2 may get any kind of its mix."""
    mix = {"passive": 0.6, "axial": 0.2, "header": 0.1, "dip": 0.1}
    large = {_by_pins(mix, 12, i).kind for i in range(60)}
    assert large == {"header", "dip"}
    assert {_by_pins(mix, 2, i).kind for i in range(60)} == set(mix)
    # A mix of two-pin parts only: the largest it has.
    assert pins(_by_pins({"passive": 1.0}, 12)) == 2


def test_joinable_pins_leave_out_what_the_largest_part_has_beyond_the_others():
    assert joinable_pins([16, 2]) == 4  # a DIP-16 and a passive: two nets at most
    assert joinable_pins([9, 9, 2, 2]) == 22
    assert joinable_pins([]) == 0


def test_the_pins_asked_for_let_the_board_reach_what_it_wants_in_one_or_two_parts():
    for counts in ([2], [2, 2], [3, 2, 2], [16, 2], [8, 8, 2], [40, 3]):
        for wanted in range(2, 60):
            first = pins_to_ask(counts, wanted)
            grown = [*counts, first]
            if joinable_pins(grown) < wanted:
                assert wanted > 2 * sum(counts), (counts, wanted)  # one part could not do it
                grown.append(pins_to_ask(grown, wanted))
            assert joinable_pins(grown) >= wanted, (counts, wanted)


def test_the_top_up_by_pin_count_reaches_the_pins_the_pad_target_needs():
    generator = level_config("d2r", "a").generator()
    assert generator.params.top_up_by_pins == 1.0
    for index in range(80):
        stream = Stream(0, 3, 0, "test", index)
        style = Style(dict(generator.params.part_mix), PASSIVES)
        templates = [generator.parts.from_mix(stream, style) for _ in range(2)]
        generator._top_up(stream, style, templates, 25)
        full = len(templates) == generator.params.components_range[1]
        assert full or joinable_pins([pins(t) for t in templates]) >= 25 * 1.1
        assert len(templates) <= 2 + 3  # one or two parts by pin count, rarely a third


def test_small_boards_come_with_large_parts_when_topped_up_by_pin_count():
    """Real small boards reach their pad count with a large connector or IC: by pin count,
    level a has far more boards of four footprints or fewer than topped up from its mix."""
    def small(by_pins: float) -> int:
        generator = level_config("d2r", "a", {"top_up_by_pins": by_pins}).generator()
        return sum(len(generator.generate(0, "test", i).board.parts) <= 4 for i in range(60))

    assert small(1.0) > small(0.0) + 4


# Level a 3.0.0's parameters (the level before `top_up_by_pins`) and three of its train
# boards' sha256 as 3.0.0 wrote them: with the top-up by pin count off, the same parameters
# still give the same bytes (the draws of the other parts did not move).
LEVEL_A_3_0_0 = {
    "components_median": 5.5, "components_sigma": 0.65, "pads_per_component_median": 3.4,
    "pads_per_component_sigma": 0.25, "top_up_by_pins": 0.0, "packed_fraction": 0.0,
    "fill_range": [0.07, 2.0], "fill_style_coupling": 0.7,
    "part_mix": {"passive": 0.22, "axial": 0.17, "radial": 0.15, "sot23": 0.05, "soic": 0.05,
                 "tssop": 0.0, "dip": 0.08, "qfn": 0.0, "qfp": 0.0, "header": 0.18,
                 "connector": 0.10}}
LEVEL_A_3_0_0_BOARDS = {
    0: "34ac67f9e47a4e914029dd09574c1fef14e9cb2c20115a52cef9a196529194b1",
    1: "d9a088569abc315bb214f3df8288bb48d7cb56bbc0ab799a39e27a8cc1099011",
    2: "755d60787cd9ace1029503600232c22655d654eb669f656b460a8e4902543752"}


def test_with_the_top_up_by_pin_count_off_boards_are_byte_identical_to_before():
    assert_train_boards_unchanged(LEVEL_A_3_0_0, LEVEL_A_3_0_0_BOARDS)


def _passive_pitches(board) -> dict[str, set[float]]:
    """Per passive size (its footprint name), the pad centre distances (mm) on a board."""
    out: dict[str, set[float]] = {}
    for part in board.parts:
        if part.name.startswith("RC_"):
            size = part.name.split("_")[1]
            a, b = part.pads
            out.setdefault(size, set()).add(round(abs(a.dx - b.dx) / 1e6, 6))
    return out


def test_land_patterns_vary_by_board_one_distance_per_size_within_its_range():
    """With `land_pattern_spread` 1 every board draws one pad centre distance per passive
    size, in the size's range, to 0.01 mm; at 0 every passive is nominal."""
    varied = level_config("d2r", "b", {"land_pattern_spread": 1.0,
                                       "land_pattern_library": 0.0}).generator()
    nominal = level_config("d2r", "b", {"land_pattern_spread": 0.0}).generator()
    seen: set[float] = set()
    for i in range(20):
        for size, distances in _passive_pitches(varied.generate(0, "test", i).board).items():
            assert len(distances) == 1
            (distance,) = distances
            low, high = fp.PASSIVE_PITCH_RANGES_MM[size]
            assert low <= distance <= high and round(distance, 2) == distance
            seen.add(distance)
        for size, distances in _passive_pitches(nominal.generate(0, "test", i).board).items():
            assert distances == {fp.PASSIVES[size][2]}
    assert len(seen) > 10


def test_the_smallest_land_pattern_keeps_its_pads_apart():
    for size, (low, _high) in fp.PASSIVE_PITCH_RANGES_MM.items():
        assert fp.min_gap(fp.passive(size, low)) >= 300_000  # 0.3 mm: above every clearance
    for size, values in fp.PASSIVE_LIBRARY_PITCHES_MM.items():  # 0.25: above 0.15 clearances
        assert fp.min_gap(fp.passive(size, min(values))) >= 250_000


_VARIANT_NAMES = (tuple(n for n, *_ in fp.RADIAL_VARIANTS)
                  + tuple(n for n, *_ in fp.THT_CONNECTORS) + fp.SOT_VARIANTS)


def test_package_variety_draws_other_packages_of_a_kind():
    """With `package_variety` 1 every SOT-23, radial part, header and connector drawn from the
    mix is another package of its kind, and the pitches they bring are many; at 0 none is."""
    varied = level_config("d2r", "c", {"package_variety": 1.0}).generator()
    plain = level_config("d2r", "c", {"package_variety": 0.0}).generator()
    names, pitches = [], set()
    for i in range(6):
        for part in varied.generate(0, "test", i).board.parts:
            names.append(part.name)
            if len(part.pads) > 1:
                pitches.add(round(min(
                    ((a.dx - b.dx) ** 2 + (a.dy - b.dy) ** 2) ** 0.5
                    for j, a in enumerate(part.pads) for b in part.pads[:j]) / 1e6, 2))
        for part in plain.generate(0, "test", i).board.parts:
            assert not part.name.startswith(_VARIANT_NAMES)
    assert not any(n in ("SOT-23",) or n.startswith("Radial_P") for n in names)
    assert any(n.startswith(fp.SOT_VARIANTS) for n in names)
    assert len(pitches) > 25


def test_every_package_variant_keeps_its_pads_apart():
    assert D2RParams(package_variety=0.5).smallest_pad_gap_mm() >= 0.2
    for template in fp.variant_templates():
        assert fp.min_gap(template) >= 200_000  # 0.2 mm: above every class clearance
        assert fp.min_pitch(template) >= 900_000

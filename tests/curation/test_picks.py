"""Characteristics order, tiers and evaluation picks against hand-computed cases."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pcbdata.curation.picks import (
    Row,
    apply_replacements,
    array_split,
    assign_tiers,
    evaluation_subsets,
    exclude_after_picks,
    number_rows,
    picks,
)
from pcbdata.sets.recipe import Override, load_recipe, parse_recipe


def rows(spec):
    """spec: list of (name, pads, nets, components, layers)."""
    return [Row(name=n, pads=p, nets=k, components=c, layers=layers)
            for n, p, k, c, layers in spec]


@pytest.mark.parametrize("n", range(0, 23))
@pytest.mark.parametrize("parts", [1, 2, 3, 10])
def test_array_split_matches_numpy(n, parts):
    assert array_split(list(range(n)), parts) == [list(c) for c in
                                                  np.array_split(np.arange(n), parts)]


def test_rows_sorted_by_pads_nets_components_name_and_numbered_from_one():
    table = number_rows(rows([("b", 10, 5, 3, 2), ("a", 10, 5, 3, 2), ("c", 10, 4, 9, 2),
                              ("d", 8, 9, 9, 4), ("e", 10, 5, 2, 2)]))
    assert [(r.row, r.name) for r in table] == [(1, "d"), (2, "c"), (3, "e"), (4, "a"), (5, "b")]
    assert table[0].board_id == "0001_d"


def test_tiers_first_rows_then_pad_threshold():
    table = number_rows(rows([(f"x{i}", i, 1, 1, 2) for i in range(1, 9)]))
    tiers = assign_tiers(table, a_size=3, b_max_pads=5)
    assert [r.name for r in tiers["A"]] == ["x1", "x2", "x3"]
    assert [r.name for r in tiers["B"]] == ["x4", "x5"]
    assert [r.name for r in tiers["C"]] == ["x6", "x7", "x8"]
    assert [r.tier for r in table] == ["A"] * 3 + ["B"] * 2 + ["C"] * 3


def test_tier_a_takes_the_first_rows_whatever_their_pads():
    table = number_rows(rows([(f"x{i}", i, 1, 1, 2) for i in range(1, 9)]))
    tiers = assign_tiers(table, a_size=6, b_max_pads=2)  # A reaches past the B/C threshold
    assert [r.name for r in tiers["A"]] == ["x1", "x2", "x3", "x4", "x5", "x6"]
    assert tiers["B"] == [] and [r.name for r in tiers["C"]] == ["x7", "x8"]
    assert [r.tier for r in table] == ["A"] * 6 + ["C"] * 2


def test_picks_bins_and_lower_median():
    # 7 two-layer boards, 3 bins -> array_split sizes 3, 2, 2 -> lower medians 1, 0, 0
    tier = rows([(f"b{p}", p, 1, 1, 2) for p in (10, 11, 12, 13, 14, 15, 16)])
    assert [r.name for r in picks(tier, bins=3)] == ["b11", "b13", "b15"]
    # 4 per bin -> index (4 - 1) // 2 = 1: the lower of the two middle boards
    tier = rows([(f"b{p}", p, 1, 1, 2) for p in range(1, 9)])
    assert [r.name for r in picks(tier, bins=2)] == ["b2", "b6"]


def test_picks_keep_two_layer_boards_only_and_sort_by_pads_nets_name():
    tier = rows([("four", 5, 1, 1, 4), ("z", 6, 2, 1, 2), ("y", 6, 2, 1, 2), ("x", 6, 1, 1, 2),
                 ("w", 7, 1, 1, 2)])
    # two-layer, sorted: x (6,1), y (6,2,"y"), z (6,2,"z"), w (7) -> 1 bin of 4 -> index 1
    assert [r.name for r in picks(tier, bins=1)] == ["y"]
    assert [r.name for r in picks(tier, bins=1, layers=None)] == ["y"]  # four first: (5) -> y
    assert [r.name for r in picks(tier, bins=4)] == ["x", "y", "z", "w"]


def test_picks_trim_largest_ten_percent_round_half_even():
    tier = rows([(f"c{p:03d}", p, 1, 1, 2) for p in range(101, 126)])  # 25 boards
    # round(2.5) = 2 -> drop c124, c125; 23 left in 10 bins: sizes 3,3,3,2,2,2,2,2,2,2
    chosen = picks(tier, bins=10, trim_fraction=0.1)
    assert [r.pads for r in chosen] == [102, 105, 108, 110, 112, 114, 116, 118, 120, 122]
    tier15 = rows([(f"c{p:03d}", p, 1, 1, 2) for p in range(1, 16)])  # round(1.5) = 2
    assert picks(tier15, bins=1, trim_fraction=0.1)[0].pads == 7  # 13 left, index 6


def test_fewer_boards_than_bins_takes_each_board():
    tier = rows([("a", 1, 1, 1, 2), ("b", 2, 1, 1, 2)])
    assert [r.name for r in picks(tier, bins=10)] == ["a", "b"]
    assert picks([], bins=10) == []


def test_replacement_override_applies_only_to_a_computed_pick_in_the_tier():
    tier = rows([("p", 1, 1, 1, 2), ("q", 1, 1, 1, 2), ("r", 2, 1, 1, 2)])
    chosen = [tier[0]]
    o = Override(kind="replace_pick", config="d3-b", board="p", replacement="q", reason="t")
    out, notes = apply_replacements(chosen, tier, "d3-b", [o])
    assert [r.name for r in out] == ["q"] and notes[0]["applied"]
    assert notes[0] == {"kind": "replace_pick", "config": "d3-b", "board": "p",
                        "replacement": "q", "reason": "t", "applied": True, "why": ""}
    out, notes = apply_replacements(chosen, tier, "d3-b", [replace(o, board="r")])
    assert [r.name for r in out] == ["p"] and not notes[0]["applied"]
    assert notes[0]["why"] == "board is not a computed pick"
    out, notes = apply_replacements(chosen, tier, "d3-b", [replace(o, replacement="nope")])
    assert not notes[0]["applied"] and notes[0]["why"] == "replacement is not in the tier"
    out, notes = apply_replacements([tier[0], tier[1]], tier, "d3-b", [o])
    assert notes[0]["why"] == "replacement is already a pick"
    assert apply_replacements(chosen, tier, "d3-c", [o]) == (chosen, [])


def test_evaluation_subsets_with_the_published_overrides():
    recipe = replace(load_recipe(), published={})  # the rule of step 6, with its overrides
    a = [("karabas-nano_wifi_revA", 1, 1, 1, 2)] + [(f"a{i}", 1 + i, 1, 1, 2) for i in range(3)]
    b = [("badge2016_Badge_init", 93, 20, 650, 2), ("cat-trainer_teensy_base_pcb", 93, 26, 28, 2)]
    table = number_rows(rows(a + b))
    tiers = {"A": table[:4], "B": table[4:], "C": []}
    subsets, notes = evaluation_subsets(tiers, recipe)
    assert "karabas-nano_wifi_revA" not in [r.name for r in subsets["A"]]
    assert len(subsets["A"]) == 3
    # two boards in 10 bins: both are picks, so the replacement is already a pick and the
    # override is reported as not applied
    assert {n["board"]: n["applied"] for n in notes}["badge2016_Badge_init"] is False


def test_published_replacement_in_its_bin():
    recipe = replace(load_recipe(), published={})  # the rule of step 6, with its overrides
    # 20 boards in B, 10 bins of 2, lower median = first of each bin; badge is the first of
    # bin 0 and cat-trainer the second (same pads, more nets) -> cat-trainer replaces it
    spec = [("badge2016_Badge_init", 93, 20, 650, 2),
            ("cat-trainer_teensy_base_pcb", 93, 26, 28, 2)]
    spec += [(f"b{i:02d}", 94 + i, 1, 1, 2) for i in range(18)]
    table = number_rows(rows(spec))
    subsets, notes = evaluation_subsets({"A": [], "B": table, "C": []}, recipe)
    names = [r.name for r in subsets["B"]]
    assert "cat-trainer_teensy_base_pcb" in names and "badge2016_Badge_init" not in names
    assert len(names) == 10
    applied = [n for n in notes if n["kind"] == "replace_pick"]
    assert applied[0]["applied"] is True


def test_recipe_rejects_overrides_without_reason():
    raw = load_recipe().text + b'\n[[overrides]]\nkind = "exclude"\nboard = "x"\nreason = ""\n'
    from pcbdata.core.errors import UserError
    with pytest.raises(UserError, match="reason"):
        parse_recipe(raw, "bad.toml")


PUBLISHED_B = ["maytal_Maytal", "ottawa-badges-2016_ottawa-badge-tagger-2016", "sensorboard_DiffIR",
               "MOD-MPU9150_mod-mpu9150", "ATtiny461Breakout_ATTiny461DevBoard",
               "NiMH-Charger_NiMH Charger", "raspberrypi-3-usb-hub_usb_hub",
               "kicad-workshop_fancyboard", "mavbridge_mavbridge", "cat-trainer_teensy_base_pcb"]
PUBLISHED_C = ["laptimer58_Chickadee", "induction-hob_temperature-sender", "uedaino_uedaino",
               "data-manager_data-manager", "kitspace_f-91w",
               "RGBMatrixPanelCPLD-PhotonBackpack_RGBMatrixPanel_CPLD_negative",
               "ozinverter_ozinverterkicad", "Brushless_ESC_Brushless_ESC",
               "RGBMatrixPanelCPLD-PhotonBackpack_RGBMatrixPanel_CPLD",
               "TOBS_HybridChargeController"]


def test_recipe_pins_the_published_test_lists():
    """SPEC section 3, step 9: the published D3-B and D3-C test picks, by name."""
    recipe = load_recipe()
    assert recipe.version == "2.0.0"
    assert sorted(recipe.published) == ["d3-b", "d3-c"]
    assert list(recipe.published["d3-b"]) == PUBLISHED_B
    assert list(recipe.published["d3-c"]) == PUBLISHED_C
    assert recipe.keep.max_unconnected is None  # step 3: open connections drop no board


def _tier(names, first_pads):
    return [(n, first_pads + i, 10, 10, 2) for i, n in enumerate(names)]


def test_published_lists_are_used_when_every_board_is_in_its_tier():
    recipe = load_recipe()
    others = [(f"z{i:02d}", 40 + i, 5, 5, 2) for i in range(30)]  # would be the rule's picks
    table = number_rows(rows(_tier(PUBLISHED_B, 10) + others))
    c_table = number_rows(rows(_tier(PUBLISHED_C, 200)))
    subsets, notes = evaluation_subsets({"A": [], "B": table, "C": c_table}, recipe)
    assert [r.name for r in subsets["B"]] == sorted(PUBLISHED_B, key=PUBLISHED_B.index)
    assert {r.name for r in subsets["C"]} == set(PUBLISHED_C)
    published = {n["config"]: n for n in notes if n["kind"] == "published_test"}
    assert published["d3-b"]["applied"] and published["d3-c"]["applied"]
    assert not any(n["kind"] == "replace_pick" for n in notes)  # the rule did not run


def test_a_missing_published_board_falls_back_to_the_rule_and_names_it():
    recipe = load_recipe()
    names = PUBLISHED_C[1:]  # laptimer58_Chickadee not kept
    table = number_rows(rows(_tier(names, 200) + _tier([f"y{i}" for i in range(20)], 300)))
    subsets, notes = evaluation_subsets({"A": [], "B": [], "C": table}, recipe)
    note = next(n for n in notes if n["kind"] == "published_test" and n["config"] == "d3-c")
    assert note["applied"] is False and note["missing"] == ["laptimer58_Chickadee"]
    assert "differs from the published one" in note["why"]
    assert [r.name for r in subsets["C"]] == [r.name for r in sorted(
        picks(table, 10, 2, 0.1), key=lambda r: r.row)]


def test_exclusion_after_the_picks_keeps_the_board_in_the_pool():
    """The zero-clearance board of D3-B is cut into the bins, then leaves its tier and the
    table, and the rows after it are numbered again (SPEC section 3, step 8)."""
    recipe = load_recipe()
    gone = "hackaday_esp-14_power_meter__autosave-esp-14"
    spec = [(f"b{i:02d}", 50 + i, 5, 5, 2) for i in range(20)]
    spec.insert(2, (gone, 51, 5, 4, 2))  # row 3 of 21: in bin 0 (3 boards), not its median
    table = number_rows(rows(spec))
    tiers = assign_tiers(table, 0, 100)
    with_it = [r.name for r in picks(table, 10, 2)]
    recipe = replace(recipe, published={})
    subsets, _ = evaluation_subsets(tiers, recipe)
    assert [r.name for r in subsets["B"]] == with_it and gone not in with_it
    kept, notes = exclude_after_picks(table, tiers, subsets,
                                      recipe.overrides("exclude_after_picks"))
    assert notes == [{**recipe.overrides("exclude_after_picks")[0].as_dict(), "applied": True,
                      "why": ""}]
    assert gone not in [r.name for r in kept] and gone not in [r.name for r in tiers["B"]]
    assert [r.row for r in kept] == list(range(1, 21))
    # without it in the pool, the bins (and so the picks) would be others
    assert with_it != [r.name for r in picks(kept, 10, 2)]


def test_exclusion_after_the_picks_refuses_a_test_pick():
    recipe = load_recipe()
    gone = "hackaday_esp-14_power_meter__autosave-esp-14"
    table = number_rows(rows([(gone, 54, 5, 4, 2)]))
    tiers = assign_tiers(table, 0, 100)
    subsets = {"A": [], "B": list(table), "C": []}
    kept, notes = exclude_after_picks(table, tiers, subsets,
                                      recipe.overrides("exclude_after_picks"))
    assert notes[0]["applied"] is False and notes[0]["why"] == "board is a test pick"
    assert [r.name for r in kept] == [gone]


def test_the_previous_recipe_stays_loadable_by_name():
    old = load_recipe("d3-1.0.0")
    assert (old.version, old.keep.max_unconnected, old.published) == ("1.0.0", 0, {})
    assert old.sha256 == "b70fe78c312589d075acbdac59245f99185dcb71051df2ca0c5c883b5f7253ae"

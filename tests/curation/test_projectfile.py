"""The project-file compatibility pass (pure data) and the recipe's SPEC numbers."""
from __future__ import annotations

import json

import pytest

from pcbdata.kicad.projectfile import default_clearance, dumps_project, patch_project
from pcbdata.sets.recipe import load_recipe

SPEC_IGNORED = {"solder_mask_bridge", "drill_out_of_range", "malformed_courtyard",
                "courtyards_overlap", "annular_width", "copper_edge_clearance",
                "hole_clearance"}


def project(clearance=0.2, severities=None):
    classes = [] if clearance is ... else [{"name": "Default", "clearance": clearance,
                                            "track_width": 0.25}]
    return {"board": {"design_settings": {
        "rule_severities": severities or {"clearance": "error", "hole_clearance": "error"},
        "rules": {"min_via_annular_width": 0.1, "min_copper_edge_clearance": 0.5,
                  "min_hole_clearance": 0.25, "min_hole_to_hole": 0.25,
                  "min_track_width": 0.2}}},
            "net_settings": {"classes": classes}, "meta": {"version": 3}}


def test_packaged_recipe_holds_the_spec_numbers():
    r = load_recipe()
    assert set(r.compat.ignore_severities) == SPEC_IGNORED
    assert r.compat.rules == {"min_via_annular_width": 0.0,
                              "min_copper_edge_clearance": 0.0, "min_hole_clearance": 0.0}
    assert r.compat.min_hole_to_hole_cap == 0.25
    assert (r.tiers.a_size, r.tiers.b_max_pads) == (100, 100)
    assert (r.picks.bins, r.picks.layers, r.picks.c_trim_fraction) == (10, 2, 0.1)
    assert r.engine.kicad_version == "9.0.8"
    kinds = {(o.kind, o.board) for o in r.all_overrides}
    assert kinds == {("exclude_from_test", "karabas-nano_wifi_revA"),
                     ("replace_pick", "badge2016_Badge_init"),
                     ("exclude_after_picks", "hackaday_esp-14_power_meter__autosave-esp-14")}
    assert (r.keep.max_errors, r.keep.max_unconnected) == (0, None)  # step 3
    assert all(o.reason.strip() for o in r.all_overrides)
    assert len(r.sha256) == 64 and r.version


def test_patch_sets_severities_and_rules():
    compat = load_recipe().compat.as_table()
    out = patch_project(project(0.2), compat)
    ds = out["board"]["design_settings"]
    assert {k for k, v in ds["rule_severities"].items() if v == "ignore"} == SPEC_IGNORED
    assert ds["rule_severities"]["clearance"] == "error"
    assert ds["rules"]["min_via_annular_width"] == 0
    assert ds["rules"]["min_copper_edge_clearance"] == 0
    assert ds["rules"]["min_hole_clearance"] == 0
    assert ds["rules"]["min_hole_to_hole"] == 0.2  # min(0.25, clearance 0.2)
    assert ds["rules"]["min_track_width"] == 0.2  # untouched
    assert patch_project(project(0.3), compat)["board"]["design_settings"]["rules"][
        "min_hole_to_hole"] == 0.25


def test_patch_does_not_touch_its_input_and_is_canonical():
    compat = load_recipe().compat.as_table()
    before = project(0.2)
    snapshot = json.dumps(before, sort_keys=True)
    text = dumps_project(patch_project(before, compat))
    assert json.dumps(before, sort_keys=True) == snapshot
    assert text == dumps_project(json.loads(text)) and text.endswith("}\n")


@pytest.mark.parametrize("clearance", [0, 0.0, None, ...])
def test_missing_clearance_becomes_the_observed_spacing(clearance):
    compat = load_recipe().compat.as_table()
    p = project(clearance)
    assert default_clearance(p) is None
    out = patch_project(p, compat, observed_spacing=0.127)
    assert default_clearance(out) == 0.127
    assert out["board"]["design_settings"]["rules"]["min_hole_to_hole"] == 0.127
    with pytest.raises(ValueError):
        patch_project(p, compat)


def test_stored_clearance_wins_over_observed_spacing():
    out = patch_project(project(0.2), load_recipe().compat.as_table(), observed_spacing=0.1)
    assert default_clearance(out) == 0.2


def test_revalidation_skips_only_warning_checks():
    from pcbdata.kicad.projectfile import check_project

    p = project(0.2, severities={"silk_overlap": "warning", "starved_thermal": "error",
                                 "clearance": "error"})
    out = check_project(p, ["silk_overlap", "starved_thermal", "text_height"])
    sev = out["board"]["design_settings"]["rule_severities"]
    assert sev["silk_overlap"] == "ignore"
    assert sev["starved_thermal"] == "error"  # an error check always runs
    assert "text_height" not in sev  # absent: severity unknown, so the check runs
    assert p["board"]["design_settings"]["rule_severities"]["silk_overlap"] == "warning"


def test_packaged_skip_list_has_no_error_default_check_left_unguarded():
    # the verdict checks are never in the list (check_project guards the rest: a listed check
    # the project makes an error, e.g. starved_thermal by KiCad 9 default, still runs)
    skip = load_recipe().keep.skip_warning_checks
    assert "clearance" not in skip and "unconnected_items" not in skip
    assert "shorting_items" not in skip


@pytest.mark.parametrize("edit, message", [
    (("b_max_pads = 100", 'b_max_pads = "many"'), r"\[tiers\] b_max_pads must be int"),
    (("max_errors = 0", "max_errors = 0.5"), r"\[keep\] max_errors must be int"),
    (("spacing_probe_mm = 2.0", "spacing_probe_mm = true"), "spacing_probe_mm must be float"),
    (("bins = 10\n", ""), r"\[picks\] lacks bins"),
])
def test_the_typed_recipe_names_a_missing_or_mistyped_key(edit, message):
    from pcbdata.core.errors import UserError
    from pcbdata.sets.recipe import parse_recipe

    raw = load_recipe().text.decode()
    assert edit[0] in raw
    with pytest.raises(UserError, match=message):
        parse_recipe(raw.replace(edit[0], edit[1], 1).encode(), "bad.toml")

"""Rules smuggled inside a submitted board are never obeyed.

KiCad obeys a board file's legacy net classes, legacy setup keys and local overrides over the
instance's project. The evaluator therefore checks the instance's own board with only the
submission's tracks, arcs and vias transplanted onto it, and reports anything else that differs
as `invalid`. Every smuggle here is a small edit of an honest routed D2 board (d2_boards.py):
- its record is `invalid`, with a reason naming what changed;
- where the copper is untouched, the transplanted board measures exactly like the honest one;
- where KiCad would obey the smuggled rule on the submitted file itself (the evaluator before
  the transplant), that is shown too: the edit really hides a violation.
"""
from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import pytest
from d2_boards import write_d2_instance, write_honest_board, write_honest_board_with_other_uuids

from pcbdata.evaluator.metrics import counted_violations, raw_counts, rollout_metrics
from pcbdata.evaluator.scorer import MEASURE
from pcbdata.kicad.drc_report import DrcReport
from pcbdata.kicad.scoring import violation_records

#: DRV of the honest board: clearance, track_width, items_not_allowed and 5 unconnected items;
#: DRV+ adds the dangling stub.
HONEST_DRV, HONEST_DRV_STRICT = 8, 9
MEASURED = ("violations", "clusters", "wl_mm", "vias", "net_count")


def before(anchor: str, block: str) -> Callable[[str], str]:
    def edit(text: str) -> str:
        assert anchor in text, anchor
        at = text.index(anchor)
        return text[:at] + block + text[at:]
    return edit


def each(old: str, new: str) -> Callable[[str], str]:
    def edit(text: str) -> str:
        assert old in text, old
        return text.replace(old, new)
    return edit


def pads(override: str) -> Callable[[str], str]:
    """The override on every pad (pads are the only items whose `(net` is three tabs deep)."""
    return each("\t\t\t(net ", f"\t\t\t{override}\n\t\t\t(net ")


def footprints(override: str) -> Callable[[str], str]:
    return each("\t\t(attr ", f"\t\t{override}\n\t\t(attr ")


def both(*edits: Callable[[str], str]) -> Callable[[str], str]:
    def edit(text: str) -> str:
        for one in edits:
            text = one(text)
        return text
    return edit


FIRST_FOOTPRINT = '\t(footprint "Pad"'
LEGACY_DEFAULT = ('\t(net_class "Default" "smuggled"\n\t\t(clearance 0)\n\t\t(trace_width 0.3)\n'
                  '\t\t(via_dia 1.2)\n\t\t(via_drill 0.6)\n\t\t(uvia_dia 0.3)\n'
                  '\t\t(uvia_drill 0.1)\n\t)\n')
LEGACY_NAMED = ('\t(net_class "Relaxed" "smuggled"\n\t\t(clearance 0.01)\n\t\t(trace_width 0.1)\n'
                '\t\t(via_dia 1.2)\n\t\t(via_drill 0.6)\n\t\t(uvia_dia 0.3)\n\t\t(uvia_drill 0.1)\n'
                '\t\t(add_net "NET2")\n\t\t(add_net "NET3")\n\t\t(add_net "NET4")\n\t)\n')
STACKUP = ('\t\t(stackup\n\t\t\t(layer "F.Cu" (type "copper") (thickness 0.035))\n'
           '\t\t\t(layer "dielectric 1" (type "core") (thickness 0.2) (material "FR4") '
           '(epsilon_r 4.5) (loss_tangent 0.02))\n'
           '\t\t\t(layer "B.Cu" (type "copper") (thickness 0.035))\n\t\t)\n')
FOUR_LAYERS = each('(2 "B.Cu" signal)', '(2 "B.Cu" signal)\n\t\t(4 "In1.Cu" signal)\n'
                                        '\t\t(6 "In2.Cu" signal)')
NET3_TRACK_LAYER = '(width 0.25)\n\t\t(layer "B.Cu")'


@dataclass(frozen=True)
class Smuggle:
    name: str
    edit: Callable[[str], str]
    reason: str  # a fragment of the record's reason
    hides: str | None = None  # the violation type KiCad stops reporting on the submitted file
    same_copper: bool = True


SMUGGLES = [
    # net classes: the legacy block KiCad 9 still reads, for the default class or a named one
    Smuggle("legacy Default net class", before(FIRST_FOOTPRINT, LEGACY_DEFAULT),
            "net classes changed (7 changed, e.g. 'class Default': Clearance=300000 -> Clearance=0",
            hides="clearance"),
    Smuggle("legacy named net class", before(FIRST_FOOTPRINT, LEGACY_NAMED),
            "e.g. 'class Default': Clearance=300000 -> Clearance=200000", hides="clearance"),
    Smuggle("legacy setup rules", each("\t(setup\n", "\t(setup\n\t\t(trace_min 0.2)\n"),
            "'board file carries legacy design settings': False -> True", hides="track_width"),
    # local overrides on pads and footprints
    Smuggle("pad clearance", pads("(clearance 0.001)"),
            "pads changed (15 changed, e.g. 'P1:1': with (clearance 0.001))", hides="clearance"),
    Smuggle("footprint clearance", footprints("(clearance 0.001)"),
            "footprints changed (15 changed, e.g. 'P1': with (clearance 0.001))",
            hides="clearance"),
    Smuggle("pad solder mask margin", pads("(solder_mask_margin 0.2)"),
            "with (solder_mask_margin 0.2)"),
    Smuggle("pad paste margin", pads("(solder_paste_margin -0.1)"),
            "with (solder_paste_margin -0.1)"),
    Smuggle("pad paste ratio", pads("(solder_paste_margin_ratio -0.5)"),
            "with (solder_paste_margin_ratio -0.5)"),
    Smuggle("pad zone connection", pads("(zone_connect 0)"), "with (zone_connect 0)"),
    Smuggle("pad thermal settings", pads("(thermal_bridge_width 0.1)\n\t\t\t(thermal_gap 0.1)"),
            "pads changed (15 changed"),
    Smuggle("footprint zone connection", footprints("(zone_connect 0)"),
            "footprints changed (15 changed, e.g. 'P1': with (zone_connect 0))"),
    Smuggle("footprint mask margin", footprints("(solder_mask_margin 0.3)"),
            "with (solder_mask_margin 0.3)"),
    Smuggle("footprint attributes", each("(attr smd)", "(attr smd allow_soldermask_bridges)"),
            "(attr smd) -> (attr smd allow_soldermask_bridges)"),
    # zones: a keepout that stops forbidding tracks, and every setting of a copper zone
    Smuggle("keepout allows tracks", each("(tracks not_allowed)", "(tracks allowed)"),
            "zones changed (1 changed, e.g. \"rule area 'keepout' on F.Cu B.Cu\": "
            "(keepout (tracks not_allowed)", hides="items_not_allowed"),
    Smuggle("zone clearance", each("(clearance 0.5)", "(clearance 0.01)"),
            "(connect_pads (clearance 0.5)) -> (connect_pads (clearance 0.01))"),
    Smuggle("zone pad connection", each("(connect_pads\n\t\t\t(clearance 0.5)",
                                        "(connect_pads no\n\t\t\t(clearance 0.5)"),
            "-> (connect_pads no (clearance 0.5))"),
    Smuggle("zone min thickness", each("(min_thickness 0.25)", "(min_thickness 0.1)"),
            "zones changed (2 changed, e.g. \"rule area 'keepout' on F.Cu B.Cu\": "
            "(min_thickness 0.25) -> (min_thickness 0.1))"),
    Smuggle("zone priority", each("(priority 1)", "(priority 7)"), "(priority 1) -> (priority 7)"),
    Smuggle("zone thermal gap", each("(thermal_gap 0.5)", "(thermal_gap 0.2)"),
            "(fill (thermal_gap 0.5) (thermal_bridge_width 0.5)) -> (fill (thermal_gap 0.2) "),
    Smuggle("zone islands", each("(thermal_bridge_width 0.5)", "(thermal_bridge_width 0.5)\n"
                                 "(island_removal_mode 2)\n(island_area_min 10)"),
            "(island_removal_mode 2) (island_area_min 10)"),
    # the setup block and the layer stack
    Smuggle("mask expansion", each("(pad_to_mask_clearance 0)", "(pad_to_mask_clearance 0.5)"),
            "board setup (layers, stackup, setup block) changed"),
    Smuggle("mask min width", each("\t(setup\n", "\t(setup\n\t\t(solder_mask_min_width 0.3)\n"),
            "'m_SolderMaskMinWidth': 0 -> 300000"),
    Smuggle("paste clearance", each("\t(setup\n", "\t(setup\n\t\t(pad_to_paste_clearance -0.1)\n"),
            "'m_SolderPasteMargin': 0 -> -100000"),
    Smuggle("mask bridges", each("(allow_soldermask_bridges_in_footprints no)",
                                 "(allow_soldermask_bridges_in_footprints yes)"),
            "'m_AllowSoldermaskBridgesInFPs': False -> True"),
    Smuggle("via tenting", each("(tenting front back)", "(tenting front)"),
            "'m_TentViasBack': True -> False"),
    Smuggle("stackup", each("\t(setup\n", "\t(setup\n" + STACKUP), "with (stackup"),
    Smuggle("board thickness", each("(thickness 1.6)", "(thickness 0.8)"),
            "'board thickness': 1600000 -> 800000"),
    Smuggle("layer type", each('(0 "F.Cu" signal)', '(0 "F.Cu" power)'),
            '(0 "F.Cu" signal) -> (0 "F.Cu" power)'),
    Smuggle("four copper layers", FOUR_LAYERS, 'with (4 "In1.Cu" signal)'),
    Smuggle("copper on a layer the instance lacks",
            both(FOUR_LAYERS, each(NET3_TRACK_LAYER, '(width 0.25)\n\t\t(layer "In1.Cu")')),
            "track at (10.2, 36) mm is on a layer the instance has no copper on (In1.Cu)",
            same_copper=False),
    Smuggle("via with another size on B.Cu",
            each('(drill 0.6)\n\t\t(layers "F.Cu" "B.Cu")\n',
                 '(drill 0.6)\n\t\t(layers "F.Cu" "B.Cu")\n\t\t(padstack (mode front_inner_back) '
                 '(layer "Inner" (size 1.2)) (layer "B.Cu" (size 0.8)))\n'),
            "via at (12.6, 70) mm has different sizes on different layers", same_copper=False),
    # rule text carried as data, and nets
    Smuggle("board property", before(FIRST_FOOTPRINT, '\t(property "rules" "(rule relax '
                                                      '(constraint clearance (min 0)))")\n'),
            "board setup (layers, stackup, setup block) changed (1 added, e.g. 'property')"),
    Smuggle("track on a net the instance lacks",
            both(each('\n\t(net 6 "NET6")\n', '\n\t(net 6 "NET6")\n\t(net 7 "SMUGGLED")\n'),
                 before(FIRST_FOOTPRINT, '\t(segment\n\t\t(start 5 5)\n\t\t(end 6 5)\n'
                                         '\t\t(width 0.3)\n\t\t(layer "F.Cu")\n'
                                         '\t\t(net 7)\n\t)\n')),
            "track at (5, 5) mm is on net 'SMUGGLED', which the instance lacks; nets changed "
            "(1 added, e.g. 'SMUGGLED')", same_copper=False),
    # not rules, but not copper either
    Smuggle("silkscreen text", before(FIRST_FOOTPRINT, '\t(gr_text "hi"\n\t\t(at 5 5 0)\n'
                                      '\t\t(layer "F.SilkS")\n\t\t(effects (font (size 1 1) '
                                      '(thickness 0.15)))\n\t)\n'),
            "drawings changed (1 added, e.g. 'gr_text on F.SilkS')"),
    Smuggle("outline", before(FIRST_FOOTPRINT, '\t(gr_line\n\t\t(start 0 0)\n\t\t(end 5 5)\n'
                              '\t\t(stroke (width 0.05) (type default))\n'
                              '\t\t(layer "Edge.Cuts")\n\t)\n'),
            "board outline changed (1 added, e.g. 'gr_line on Edge.Cuts')"),
]


@pytest.fixture(scope="module")
def d2(tmp_path_factory):
    folder = tmp_path_factory.mktemp("smuggling")
    instance = write_d2_instance(folder / "instance")
    honest = write_honest_board(folder / "honest" / "routed.kicad_pcb")
    return {"folder": folder, "instance": instance, "honest": honest,
            "text": honest.read_text(encoding="utf-8")}


@pytest.fixture(scope="module")
def honest(d2, evaluator, kicad_pool):
    bare = kicad_pool.call(MEASURE, str(d2["instance"] / "board.kicad_pcb"), str(d2["instance"]))
    return {"record": evaluator.score(d2["instance"], d2["honest"]), "bare": bare,
            "measured": kicad_pool.call(MEASURE, str(d2["honest"]), str(d2["instance"]))}


def smuggled_board(d2, smuggle: Smuggle):
    path = d2["folder"] / re.sub(r"\W+", "_", smuggle.name) / "routed.kicad_pcb"
    path.parent.mkdir(exist_ok=True)
    path.write_text(smuggle.edit(d2["text"]), encoding="utf-8")
    return path


def counted_types(report: dict) -> set[str]:
    return {v["type"] for v in counted_violations(report["violations"])}


def test_the_honest_board(honest):
    r = honest["record"]
    assert r["status"] == "ok", r["reason"]
    assert (r["drv"], r["drv_strict"], r["unconnected"], r["via"]) == (
        HONEST_DRV, HONEST_DRV_STRICT, 5, 1)
    assert set(r["drv_by_type"]) == {"clearance", "track_width", "items_not_allowed",
                                     "unconnected_items"}
    assert honest["measured"]["copper_problems"] == []


def without_timing(record: dict) -> dict:
    return {k: v for k, v in record.items() if k != "score_seconds"}


def test_the_transplant_is_faithful(d2, honest, kicad_pool):
    # the copper rebuilt on the instance's board is checked exactly as the submitted file is
    direct = kicad_pool.call("pcbdata.kicad.basics:drc", str(d2["honest"]),
                             str(d2["instance"] / "board.kicad_pro"))
    assert honest["measured"]["violations"] == violation_records(DrcReport.from_dict(direct))


def test_honest_rewrites_stay_valid(d2, evaluator, kicad_pool, honest):
    # KiCad rewrites the whole file (a router built on pcbnew); another writer mints new UUIDs
    saved = d2["folder"] / "saved" / "routed.kicad_pcb"
    saved.parent.mkdir()
    kicad_pool.call("d2_boards:save_with_kicad", str(d2["honest"]), str(saved))
    assert saved.read_text(encoding="utf-8") != d2["text"]
    other = write_honest_board_with_other_uuids(d2["folder"] / "uuids" / "routed.kicad_pcb")
    for board in (saved, other):
        record = evaluator.score(d2["instance"], board)
        assert without_timing(record) == without_timing(honest["record"]), record["reason"]


@pytest.mark.parametrize("smuggle", SMUGGLES, ids=[s.name for s in SMUGGLES])
def test_smuggled_rules_make_the_rollout_invalid(d2, evaluator, smuggle):
    record = evaluator.score(d2["instance"], smuggled_board(d2, smuggle))
    assert record["status"] == "invalid", f"{smuggle.name} passed: {record}"
    assert smuggle.reason in record["reason"]
    assert (record["cp"], record["cp_strict"], record["pot"]) == (0, 0, None)


@pytest.mark.parametrize("smuggle", [s for s in SMUGGLES if s.same_copper],
                         ids=[s.name for s in SMUGGLES if s.same_copper])
def test_transplanted_copper_measures_like_the_honest_board(d2, honest, kicad_pool, smuggle):
    measured = kicad_pool.call(MEASURE, str(smuggled_board(d2, smuggle)), str(d2["instance"]))
    assert {k: measured[k] for k in MEASURED} == {k: honest["measured"][k] for k in MEASURED}
    assert measured["copper_problems"] == []
    scores = rollout_metrics(raw_counts(honest["bare"], measured))
    assert scores == {k: honest["record"][k] for k in scores}


@pytest.mark.parametrize("smuggle", [s for s in SMUGGLES if s.hides],
                         ids=[s.name for s in SMUGGLES if s.hides])
def test_kicad_obeys_the_smuggled_rule_on_the_submitted_file(d2, kicad_pool, smuggle):
    # The evaluator before the transplant: the submitted file itself, staged with the
    # instance's project. The smuggled rule hid a violation there.
    def drc(path):
        return kicad_pool.call("pcbdata.kicad.basics:drc", str(path),
                               str(d2["instance"] / "board.kicad_pro"))

    assert smuggle.hides in counted_types(drc(d2["honest"]))
    assert smuggle.hides not in counted_types(drc(smuggled_board(d2, smuggle)))


def test_rule_text_kicad_cannot_read_is_a_parse_failure(d2, evaluator):
    edit = before(FIRST_FOOTPRINT, '\t(rule "relax"\n\t\t(constraint clearance (min 0))\n\t)\n')
    record = evaluator.score(d2["instance"],
                             smuggled_board(d2, Smuggle("rule block", edit, "")))
    assert record["status"] == "parse_fail" and "could not load" in record["reason"]


def test_rules_beside_the_submission_are_ignored(d2, evaluator, honest):
    # A router that saves with KiCad leaves <stem>.kicad_pro next to its board; a relaxed one
    # (and custom rules) beside the submission changes nothing: the record is the honest one.
    folder = d2["folder"] / "sidecars"
    folder.mkdir()
    board = folder / "routed.kicad_pcb"
    board.write_text(d2["text"], encoding="utf-8")
    (folder / "routed.kicad_dru").write_text(
        '(version 1)\n(rule "relax"\n\t(constraint clearance (min 0))\n'
        '\t(constraint track_width (min 0.01))\n)\n', encoding="utf-8")
    (folder / "routed.kicad_pro").write_text(
        '{"board": {"design_settings": {"rules": {"min_track_width": 0.01}, '
        '"rule_severities": {"clearance": "ignore", "items_not_allowed": "ignore"}}}, '
        '"net_settings": {"classes": [{"name": "Default", "clearance": 0.0}]}}', encoding="utf-8")
    assert without_timing(evaluator.score(d2["instance"], board)) == without_timing(
        honest["record"])

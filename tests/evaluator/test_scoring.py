"""Every metric pinned on hand-made boards, measured by KiCad (see boards.py)."""
from __future__ import annotations

import math
from dataclasses import replace

import pytest
from boards import (
    ROUTE_A,
    ROUTE_B,
    base_board,
    pad,
    routed,
    track,
    via,
    write_board,
    write_instance,
)

from pcbdata.model.board import Arc, mm_to_nm

# bare board: U0 = 2 (one open edge per net), f0 = 3 ln(1 + 2/2) + 2 ln(1 + 1/2), N = 3
PHI_BARE = -2 - (3 * math.log(2) + 2 * math.log(1.5))
LN_1_PLUS_N = math.log(4)


@pytest.fixture(scope="module")
def instance(tmp_path_factory):
    return write_instance(base_board(), tmp_path_factory.mktemp("instance") / "inst")


def score(evaluator, instance, tmp_path, board, name="routed"):
    return evaluator.score(instance, write_board(board, tmp_path / f"{name}.kicad_pcb"))


def test_clean_routed_board(evaluator, instance, tmp_path):
    r = score(evaluator, instance, tmp_path, routed(base_board(), [ROUTE_A, ROUTE_B]))
    assert r["status"] == "ok", r["reason"]
    assert (r["cp"], r["rout"], r["drv"], r["unconnected"], r["via"]) == (1, 1.0, 0, 0, 0)
    assert r["wl"] == pytest.approx(80.0)
    assert r["net_count"] == 3  # BOARD.GetNetCount() counts the unconnected net
    assert r["phi_bare"] == pytest.approx(PHI_BARE)
    assert r["pot"] == pytest.approx(LN_1_PLUS_N - 0.002 * 80 - PHI_BARE)


def test_bare_board_scores_zero_gain(evaluator, instance):
    r = evaluator.score(instance, instance / "board.kicad_pcb")
    assert (r["status"], r["cp"], r["rout"], r["drv"], r["unconnected"]) == ("ok", 0, 0.0, 2, 2)
    assert r["pot"] == pytest.approx(0.0)


def test_half_routed_board(evaluator, instance, tmp_path):
    r = score(evaluator, instance, tmp_path, routed(base_board(), [ROUTE_A]))
    assert (r["cp"], r["rout"], r["drv"], r["unconnected"]) == (0, 0.5, 1, 1)
    f = 3 * math.log(1.5) + math.log(1.5)  # one violation (net B): X = 1, x_B = 1
    assert r["penalty"] == pytest.approx(f)
    assert r["pot"] == pytest.approx(-1 - f - 0.002 * 40 - PHI_BARE)


def test_clearance_violation(evaluator, instance, tmp_path):
    # B detours to y = 10.5: its copper edge is 0.2 mm from track A (clearance 0.3)
    detour = [track(10, 30, 20, 30, "B"), track(20, 30, 20, 10.5, "B"),
              track(20, 10.5, 40, 10.5, "B"), track(40, 10.5, 40, 30, "B"),
              track(40, 30, 50, 30, "B")]
    r = score(evaluator, instance, tmp_path, routed(base_board(), [ROUTE_A, *detour]))
    assert r["rout"] == 1.0 and r["unconnected"] == 0 and r["cp"] == 0
    assert set(r["drv_by_type"]) == {"clearance"}
    assert r["drv"] == r["drv_by_type"]["clearance"] >= 1
    x = r["drv"]  # each clearance violation names nets A and B
    assert r["penalty"] == pytest.approx(3 * math.log(2) + 2 * math.log1p(x / 2))


def test_dangling_track(evaluator, instance, tmp_path):
    # a warning: not in the evaluation count (DRV, CP, Pot.), in the strict one (DRV+, CP+)
    stub = track(30, 10, 30, 20, "A")
    r = score(evaluator, instance, tmp_path, routed(base_board(), [ROUTE_A, ROUTE_B, stub]))
    assert (r["cp"], r["rout"], r["drv"], r["drv_by_type"]) == (1, 1.0, 0, {})
    assert (r["cp_strict"], r["drv_strict"], r["drv_strict_by_type"]) == (
        0, 1, {"track_dangling": 1})
    assert r["wl"] == pytest.approx(90.0)
    assert r["pot_evaluation"] == pytest.approx(LN_1_PLUS_N - 0.002 * 90 - PHI_BARE)
    assert r["pot"] == pytest.approx(LN_1_PLUS_N - 3 * math.log(1.5) - math.log(1.5)
                                            - 0.002 * 90 - PHI_BARE)


def test_short_between_two_nets(evaluator, instance, tmp_path):
    bridge = track(50, 10, 50, 30, "A")  # net A copper onto pad B2
    r = score(evaluator, instance, tmp_path, routed(base_board(), [ROUTE_A, ROUTE_B, bridge]))
    assert r["cp"] == 0 and r["rout"] == 1.0
    assert r["drv_by_type"].get("shorting_items", 0) >= 1
    x = r["drv"]  # every violation here names both nets: x_A = x_B = DRV, X = 2
    assert r["penalty"] == pytest.approx(3 * math.log(2) + 2 * math.log1p(x / 2))


def test_arc_track_length(evaluator, instance, tmp_path):
    # A as an arc through (30, 20): circle centre (30, -5), radius 25, angle 2 asin(0.8)
    arc = Arc(mm_to_nm(10), mm_to_nm(10), mm_to_nm(30), mm_to_nm(20), mm_to_nm(50),
              mm_to_nm(10), ROUTE_A.width, "A")
    r = score(evaluator, instance, tmp_path, routed(base_board(), [ROUTE_B], arcs=[arc]))
    arc_length = 2 * 25 * math.asin(0.8)
    assert r["status"] == "ok" and r["cp"] == 1
    assert r["wl"] == pytest.approx(40 + arc_length, abs=1e-3)  # not the 40 mm chord


def test_vias_counted_and_weighted(evaluator, instance, tmp_path):
    a = [track(10, 10, 20, 10, "A"), track(20, 10, 40, 10, "A", "B.Cu"), track(40, 10, 50, 10, "A")]
    r = score(evaluator, instance, tmp_path,
              routed(base_board(), [*a, ROUTE_B], vias=[via(20, 10, "A"), via(40, 10, "A")]))
    assert (r["cp"], r["via"], r["drv"]) == (1, 2, 0)
    assert r["pot"] == pytest.approx(LN_1_PLUS_N - 0.002 * 80 - 0.1 * 2 - PHI_BARE)


def test_routability_counts_pad_clusters_not_ratsnest(evaluator, instance, tmp_path):
    # an orphan A track touching no pad adds ratsnest edges (U) but not pad clusters
    orphan = track(25, 20, 35, 20, "A")
    r = score(evaluator, instance, tmp_path, routed(base_board(), [ROUTE_B, orphan]))
    assert r["rout"] == 0.5
    assert r["unconnected"] >= 1


def test_d1_one_layer_rule(evaluator, tmp_path):
    from pcbdata.generators.d1 import D1Generator, D1Params

    inst = D1Generator(D1Params(grid=10, placement="random-walk")).generate(0, "test", 0)
    directory = write_instance(inst.board, tmp_path / "d1")
    assert (directory / "board.kicad_dru").is_file()
    ref = evaluator.score(directory, write_board(inst.reference, tmp_path / "ref.kicad_pcb"))
    assert (ref["cp"], ref["rout"], ref["drv"]) == (1, 1.0, 0)
    tracks = list(inst.reference.tracks)
    tracks[0] = replace(tracks[0], layer="B.Cu")
    bad = evaluator.score(directory, write_board(replace(inst.reference, tracks=tracks),
                                                 tmp_path / "bcu.kicad_pcb"))
    assert bad["cp"] == 0 and bad["drv_by_type"].get("items_not_allowed", 0) >= 1


def test_submission_rules_are_ignored(evaluator, instance, tmp_path):
    # a submission shipping a permissive project next to the board is scored with the
    # instance's project all the same
    folder = tmp_path / "sub"
    board = write_board(routed(base_board(), [ROUTE_A, ROUTE_B, track(30, 10, 30, 20, "A")]),
                        folder / "board.kicad_pcb")
    (folder / "board.kicad_pro").write_text('{"board": {"design_settings": {"rule_severities": '
                                            '{"track_dangling": "ignore"}}}}')
    assert evaluator.score(instance, board)["drv_strict_by_type"] == {"track_dangling": 1}


@pytest.mark.parametrize("change, category", [
    (lambda b: replace(b, pads=[pad(11, 10, "A")] + b.pads[1:]),
     "footprints changed (1 changed, e.g. 'P1': (at 10 10) -> (at 11 10))"),
    (lambda b: replace(b, pads=b.pads[:3]), "pads changed (1 missing, e.g. 'P4:1')"),
    (lambda b: replace(b, pads=[replace(b.pads[0], size=mm_to_nm(2))] + b.pads[1:]),
     "pads changed (1 changed, e.g. 'P1:1': (size 2.4 2.4) -> (size 2 2))"),
    (lambda b: replace(b, width=mm_to_nm(61)), "board outline changed"),
    (lambda b: replace(b, pads=b.pads + [pad(30, 20, "C"), pad(30, 25, "C")]), "nets changed"),
])
def test_integrity_violations_are_invalid(evaluator, instance, tmp_path, change, category):
    board = change(routed(base_board(), [ROUTE_A, ROUTE_B]))
    r = score(evaluator, instance, tmp_path, board)
    assert r["status"] == "invalid" and r["cp"] == 0
    assert category in r["reason"]


def test_changed_board_file_rules_are_invalid(evaluator, instance, tmp_path):
    board = routed(base_board(), [ROUTE_A, ROUTE_B])
    text = write_board(board, tmp_path / "a.kicad_pcb").read_text()
    path = tmp_path / "mask.kicad_pcb"
    path.write_text(text.replace("(pad_to_mask_clearance 0)", "(pad_to_mask_clearance 0.5)"))
    r = evaluator.score(instance, path)
    assert r["status"] == "invalid" and "rules" in r["reason"]


def test_wrong_instance_is_invalid(evaluator, instance, tmp_path):
    other = replace(base_board(), pads=[pad(12, 10, "A"), pad(50, 10, "A"), pad(10, 30, "B"),
                                        pad(50, 30, "B")])
    r = score(evaluator, instance, tmp_path, other)
    assert r["status"] == "invalid" and "footprints changed" in r["reason"]


@pytest.mark.parametrize("content, reason", [
    (b"", "empty file"),
    (b"hello, I am not a board\n", "not a .kicad_pcb file"),
    (b"\x89PNG\r\n\x1a\n\0\0\0", "binary data"),
])
def test_non_boards_are_parse_failures(evaluator, instance, tmp_path, content, reason):
    path = tmp_path / "bad.kicad_pcb"
    path.write_bytes(content)
    r = evaluator.score(instance, path)
    assert r["status"] == "parse_fail" and reason in r["reason"] and r["cp"] == 0


def test_truncated_board_is_a_parse_failure(evaluator, instance, tmp_path):
    board = routed(base_board(), [ROUTE_A, ROUTE_B])
    text = write_board(board, tmp_path / "full.kicad_pcb").read_text()
    path = tmp_path / "cut.kicad_pcb"
    path.write_text(text[: len(text) // 2])
    r = evaluator.score(instance, path)
    assert r["status"] == "parse_fail" and r["reason"] and r["cp"] == 0


def test_module_level_score_api(instance, tmp_path):
    from pcbdata.evaluator import score as score_one

    record = score_one(instance, write_board(routed(base_board(), [ROUTE_A, ROUTE_B]),
                                             tmp_path / "r.kicad_pcb"))
    assert (record["status"], record["cp"], record["wl"]) == ("ok", 1, 80.0)

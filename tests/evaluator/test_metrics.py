"""The pure math of SPEC section 4 on synthetic measurements (no KiCad)."""
from __future__ import annotations

import json
import math

import pytest

from pcbdata.evaluator.integrity import integrity_problems
from pcbdata.evaluator.metrics import (
    NO_NET,
    Weights,
    counted_violations,
    drc_penalty,
    is_counted,
    pick_best,
    potential,
    raw_counts,
    rollout_metrics,
    routability,
    selection_key,
    unconnected_count,
    violations_per_net,
)
from pcbdata.evaluator.runs import board_row, markdown_table, natural_key, summarize


def v(type_, severity="error", section="violations", nets=("A",)):
    return {"type": type_, "severity": severity, "section": section, "nets": list(nets)}


def test_counted_buckets():
    for counting in ("evaluation", "strict"):
        assert is_counted(v("clearance"), counting)
        assert is_counted(v("unconnected_items", section="unconnected"), counting)
        assert is_counted(v("unconnected_items", severity="warning", section="unconnected"),
                          counting)
        assert not is_counted(v("silk_overlap", severity="warning"), counting)
        assert not is_counted(v("clearance", severity="ignore"), counting)
        assert not is_counted(v("clearance", severity="excluded"), counting)
        assert not is_counted(v("track_dangling", severity="excluded"), counting)
        assert not is_counted(v("unconnected_items", severity="excluded", section="unconnected"),
                              counting)
    for kind in ("via_dangling", "track_dangling", "net_conflict"):
        assert is_counted(v(kind, severity="warning"), "strict")
        assert not is_counted(v(kind, severity="warning"), "evaluation")
        assert not is_counted(v(kind, severity="warning"))  # the evaluation count by default
        assert is_counted(v(kind, severity="error"))  # a project may make them errors
    mixed = [v("clearance"), v("silk_overlap", severity="warning"),
             v("via_dangling", severity="warning")]
    assert [x["type"] for x in counted_violations(mixed)] == ["clearance"]
    assert [x["type"] for x in counted_violations(mixed, "strict")] == ["clearance", "via_dangling"]
    with pytest.raises(ValueError, match="counting"):
        is_counted(v("clearance"), "lenient")


def test_unconnected_count_skips_excluded():
    items = [v("unconnected_items", section="unconnected"),
             v("unconnected_items", section="unconnected", severity="excluded"),
             v("clearance")]
    assert unconnected_count(items) == 1


def test_penalty_counts_two_net_violations_for_both_nets_and_no_net_once():
    counted = [v("shorting_items", nets=("A", "B")), v("clearance", nets=("A",)),
               v("copper_edge_clearance", nets=()), v("items_not_allowed", nets=())]
    assert violations_per_net(counted) == {"A": 2, "B": 1, NO_NET: 2}
    expected = (3 * math.log(1 + 3 / 2) + math.log(1 + 2 / 2) + math.log(1 + 1 / 2)
                + math.log(1 + 2 / 2))
    assert drc_penalty(counted) == pytest.approx(expected)
    assert drc_penalty([]) == 0.0
    assert drc_penalty(counted, Weights(net_weight=0.0)) == pytest.approx(
        expected - 3 * math.log(2.5))


def test_routability():
    assert routability({"A": 2, "B": 2}, {"A": 1, "B": 2}) == 0.5
    assert routability({"A": 3, "B": 2, "C": 1}, {"A": 1, "B": 1, "C": 1}) == 1.0
    assert routability({"A": 3, "B": 2}, {"A": 2, "B": 2}) == pytest.approx(1 / 3)
    assert routability({"A": 1}, {"A": 1}) == 1.0  # nothing to connect
    assert routability({}, {}) == 1.0
    assert routability({"A": 2}, {}) == 0.0  # a net that disappeared is unrouted


def test_potential():
    assert potential(3, 0, 0.0, 80.0, 0) == pytest.approx(math.log(4) - 0.16)
    assert potential(3, 2, 1.5, 10.0, 2) == pytest.approx(-2 - 1.5 - 0.02 - 0.2)
    assert potential(3, 0, 0.0, 10.0, 1, Weights(lw=0.01, lv=1.0)) == pytest.approx(
        math.log(4) - 0.1 - 1.0)


def measurement(violations, clusters, wl=0.0, vias=0, nets=3):
    return {"loaded": True, "violations": violations, "clusters": clusters, "wl_mm": wl,
            "vias": vias, "net_count": nets, "fingerprint": {}}


def scores(bare: dict, routed: dict) -> dict:
    """The figures of a rollout, from the raw counts the evaluator keeps (as it caches them)."""
    return rollout_metrics(json.loads(json.dumps(raw_counts(bare, routed))))


def test_rollout_metrics_clean_and_gain():
    bare = measurement([v("unconnected_items", section="unconnected", nets=("A",)),
                        v("unconnected_items", section="unconnected", nets=("B",))],
                       {"A": 2, "B": 2})
    routed = measurement([], {"A": 1, "B": 1}, wl=80.0)
    m = scores(bare, routed)
    phi_bare = -2 - (3 * math.log(2) + 2 * math.log(1.5))
    assert m["phi_bare"] == pytest.approx(phi_bare)
    assert m["pot"] == pytest.approx(math.log(4) - 0.16 - phi_bare)
    assert (m["cp"], m["rout"], m["drv"], m["wl"], m["via"]) == (1, 1.0, 0, 80.0, 0)
    assert (m["cp_strict"], m["drv_strict"], m["pot_evaluation"]) == (1, 0, m["pot"])
    # routability 1 and one dangling-track warning: a clean pass, not a strict one (CP+)
    m = scores(bare, measurement([v("track_dangling", severity="warning")],
                                          {"A": 1, "B": 1}))
    assert (m["cp"], m["drv"], m["drv_by_type"]) == (1, 0, {})
    assert (m["cp_strict"], m["drv_strict"], m["drv_strict_by_type"]) == (
        0, 1, {"track_dangling": 1})
    f = 3 * math.log(1.5) + math.log(1.5)
    assert m["penalty"] == pytest.approx(f) and m["penalty_evaluation"] == 0.0
    assert m["pot_evaluation"] - m["pot"] == pytest.approx(f)
    assert m["phi_bare"] == m["phi_bare_evaluation"]  # the bare board has no warnings


def test_board_state_takes_the_counting():
    from pcbdata.evaluator.metrics import board_state

    board = {"violations": [v("clearance", nets=("A", "B")), v("via_dangling", severity="warning"),
                            v("unconnected_items", section="unconnected", nets=("B",))],
             "wl_mm": 10.0, "vias": 1, "net_count": 3}
    evaluation, strict = board_state(board, counting="evaluation"), board_state(board)
    assert (evaluation["drv"], strict["drv"]) == (2, 3)
    assert evaluation["unconnected"] == strict["unconnected"] == 1
    assert strict["penalty"] > evaluation["penalty"] and strict["phi"] < evaluation["phi"]
    assert board_state(board, counting="strict") == strict  # the default: Pot.'s count


def rec(index, pot, rout=1.0, drv=0, wl=10.0, via=0, status="ok"):
    return {"index": index, "rollout": str(index), "status": status, "pot": pot, "rout": rout,
            "drv": drv, "wl": wl, "via": via, "cp": int(rout == 1 and drv == 0),
            "unconnected": 0}


def test_tie_break_order():
    assert pick_best([rec(0, 1.0), rec(1, 2.0)])["index"] == 1  # larger Pot.
    assert pick_best([rec(0, 1.0, rout=0.5), rec(1, 1.0, rout=1.0)])["index"] == 1
    assert pick_best([rec(0, 1.0, drv=2), rec(1, 1.0, drv=1)])["index"] == 1
    assert pick_best([rec(0, 1.0, wl=20), rec(1, 1.0, wl=10)])["index"] == 1
    assert pick_best([rec(0, 1.0, via=3), rec(1, 1.0, via=2)])["index"] == 1
    assert pick_best([rec(0, 1.0), rec(1, 1.0)])["index"] == 0  # full tie: lower index
    assert pick_best([rec(0, 9.0, status="invalid"), rec(1, 1.0)])["index"] == 1
    assert pick_best([rec(0, 9.0, status="parse_fail")]) is None
    assert selection_key(rec(0, 1.0)) < selection_key(rec(1, 1.0))


def test_board_and_set_summary():
    failed = {"index": 0, "rollout": "0", "status": "parse_fail", "pot": None, "rout": 0.0,
              "drv": None, "wl": None, "via": None, "cp": 0, "unconnected": None, "time": 4.0}
    good = [{**rec(0, 2.0), "time": 1.0}, {**rec(1, 3.0, drv=1), "time": 3.0}]
    rows = [board_row("b0", good), board_row("b1", [failed])]
    assert rows[0]["best_rollout"] == "1" and rows[0]["cp"] == 0 and rows[0]["time"] == 2.0
    assert rows[1]["parse_fail"] == 1 and rows[1]["cp"] == 0 and rows[1]["rout"] == 0.0
    s = summarize(rows, good + [failed], k=5)
    assert s["n_boards"] == 2 and s["k"] == 5
    # b1 has no scored rollout: it counts as its bare board (Pot. 0) in Pot., not in DRV
    assert s["cp"] == 0.0 and s["rout"] == 0.5 and s["pot"] == 1.5 and s["drv"] == 1
    assert rows[1]["pot"] == 0.0 and rows[1]["drv"] is None and s["n_boards_scored"] == 1
    assert s["time"] == pytest.approx(8 / 3)  # mean over all rollouts' times
    assert s["parse_fail"] == 0.5 and s["parse_fail_at1"] == pytest.approx(1 / 3)
    assert s["invalid"] == 0.0
    for key in ("n_boards", "k", "cp", "pot", "rout", "drv", "wl", "via", "time", "parse_fail",
                "parse_fail_at1", "invalid"):
        assert key in s
    table = markdown_table([("m", s)])
    assert table.splitlines()[0].startswith("| Method | CP (%) | Pot. | Rout. | DRV | WL")


def test_natural_rollout_order():
    assert sorted(["10", "2", "1"], key=natural_key) == ["1", "2", "10"]


def test_integrity_reports_each_changed_category():
    bare = {"nets": ["A", "B"], "pads": ["P1:1|0,0|x", "P2:1|5,5|x"], "zones": [], "outline": ["e"]}
    assert integrity_problems(bare, dict(bare)) == []
    moved = {**bare, "pads": ["P1:1|0,0|x", "P2:1|6,5|x"], "outline": []}
    problems = integrity_problems(bare, moved)
    assert problems == ["pads changed (1 changed, e.g. 'P2:1': 5,5 -> 6,5)",
                        "board outline changed (1 missing, e.g. 'e')"]


def test_integrity_names_what_changed():
    from pcbdata.evaluator.integrity import describe_change, rollout_problems

    assert describe_change("P1|(at 1 2)|(size 2 2)", "P1|(at 1 2)|(size 2 2)|(clearance 0.001)") \
        == "with (clearance 0.001)"
    assert describe_change("class Default|Clearance=300000|TrackWidth=300000",
                           "class Default|Clearance=0|TrackWidth=100000") \
        == "Clearance=300000 -> Clearance=0 (and 1 more)"
    assert describe_change("m_MinClearance|0", "m_MinClearance|100000") == "0 -> 100000"
    assert describe_change("x|(a 1)|(b 2)", "x|(b 2)|(a 1)|(b 2)") == "with (b 2)"
    fingerprint = {"nets": ["A"], "pads": ["P10:1|x", "P2:1|x"]}
    changed = {"nets": ["A"], "pads": ["P10:1|y", "P2:1|y"]}
    routed = {"fingerprint": changed, "copper_problems": ["via at (1, 2) mm is on net 'Z', ..."]}
    assert rollout_problems({"fingerprint": fingerprint}, routed) == [
        "via at (1, 2) mm is on net 'Z', ...", "pads changed (2 changed, e.g. 'P2:1': x -> y)"]

"""The two counts of SPEC 4 (revised): the evaluation count (DRV, CP, f, Phi, Pot.) and the
strict count (DRV+, CP+), in records, reports and the Markdown table."""
from __future__ import annotations

import json
import math

import pytest
from boards import ROUTE_A, ROUTE_B, base_board, routed, track, write_board, write_instance

from pcbdata.evaluator.runs import board_row, markdown_table, summarize
from pcbdata.testing.sets import seal_set

STUB = track(30, 10, 30, 20, "A")  # a dangling track: a warning unless the project says error


def with_severity(folder, check: str, severity: str):
    project = folder / "board.kicad_pro"
    data = json.loads(project.read_text())
    data["board"]["design_settings"]["rule_severities"] = {check: severity}
    project.write_text(json.dumps(data))
    return folder


@pytest.mark.parametrize("severity, drv, drv_strict", [
    ("warning", 0, 1),  # the default: the strict count only
    ("error", 1, 1),  # the project makes it an error: counted everywhere
    ("ignore", 0, 0),
])
def test_the_project_resolves_the_severity(evaluator, tmp_path, severity, drv, drv_strict):
    instance = with_severity(write_instance(base_board(), tmp_path / "inst"), "track_dangling",
                             severity)
    board = write_board(routed(base_board(), [ROUTE_A, ROUTE_B, STUB]), tmp_path / "r.kicad_pcb")
    r = evaluator.score(instance, board)
    assert (r["status"], r["drv"], r["drv_strict"]) == ("ok", drv, drv_strict)
    assert (r["cp"], r["cp_strict"]) == (int(drv == 0), int(drv_strict == 0))
    f = 3 * math.log(1.5) + math.log(1.5)  # one violation on net A
    assert r["penalty_evaluation"] == pytest.approx(f if drv else 0.0)
    assert r["penalty"] == pytest.approx(f if drv_strict else 0.0)  # Pot.'s f: strict count
    assert r["pot_evaluation"] - r["pot"] == pytest.approx(r["penalty"] - r["penalty_evaluation"])


def rec(index, cp, drv, cp_strict, drv_strict, pot=1.0):
    return {"index": index, "rollout": str(index), "status": "ok", "pot": pot, "rout": 1.0,
            "drv": drv, "wl": 10.0, "via": 0, "cp": cp, "unconnected": 0, "cp_strict": cp_strict,
            "drv_strict": drv_strict, "time": 1.0}


def test_board_rows_and_summary_carry_both_counts():
    rows = [board_row("b0", [rec(0, 1, 0, 0, 2)]), board_row("b1", [rec(0, 1, 0, 1, 0)]),
            board_row("b2", [{**rec(0, 0, None, 0, None), "status": "parse_fail"}])]
    assert (rows[0]["cp"], rows[0]["cp_strict"], rows[0]["drv_strict"]) == (1, 0, 2)
    assert (rows[2]["cp_strict"], rows[2]["drv_strict"]) == (0, None)
    s = summarize(rows, [rec(0, 1, 0, 0, 2)], k=1)
    assert s["cp"] == pytest.approx(2 / 3) and s["cp_strict"] == pytest.approx(1 / 3)
    assert s["drv"] == 0.0 and s["drv_strict"] == 1.0
    table = markdown_table([("m", s)]).splitlines()
    assert table[0] == ("| Method | CP (%) | Pot. | Rout. | DRV | WL (mm) | Via | Time (s) | "
                        "CP+ (%) | DRV+ | Parse-fail (%) | Parse-fail @1 (%) | Invalid (%) |")
    assert table[2].startswith("| m | 66.7 | 0.67 | 0.667 | 0.00 | 10.0 | 0.00 | 1.00 | "
                               "33.3 | 1.00 |")


def test_reports_have_the_strict_columns(tmp_path):
    import csv

    from pcbdata.evaluator import evaluate_set

    root, runs = tmp_path / "set", tmp_path / "runs" / "m"
    seal_set(write_instance(base_board(), root / "d2" / "test" / "b0").parents[2])
    write_board(routed(base_board(), [ROUTE_A, ROUTE_B, STUB]), runs / "b0" / "0.kicad_pcb")
    result = evaluate_set(root, "d2", "test", tmp_path / "rep", runs=runs, k=1, progress=False)
    with open(tmp_path / "rep" / "per_rollout.csv", newline="") as handle:
        row = next(csv.DictReader(handle))
    assert (row["cp"], row["drv"], row["cp_strict"], row["drv_strict"]) == ("1", "0", "0", "1")
    assert json.loads(row["drv_strict_by_type"]) == {"track_dangling": 1}
    assert float(row["pot_evaluation"]) > float(row["pot"])
    with open(tmp_path / "rep" / "per_board.csv", newline="") as handle:
        board = next(csv.DictReader(handle))
    assert (board["cp_strict"], board["drv_strict"]) == ("0", "1")
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert (summary["cp"], summary["cp_strict"], summary["drv"], summary["drv_strict"]) == (
        1.0, 0.0, 0.0, 1.0)
    assert "| 100.0 |" in result["table"] and "| 0.0 | 1.00 |" in result["table"]

"""`pcbdata eval` on bad input: options out of range are one line (exit 2, no report);
bad sidecars and stray RUNS entries never stop the run and are never dropped silently."""
from __future__ import annotations

import csv
import json

import pytest
from boards import ROUTE_A, ROUTE_B, base_board, routed, write_board, write_instance

from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.evaluator.runs import evaluate_set
from pcbdata.testing.sets import seal_set


@pytest.fixture(scope="module")
def board_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("set")
    for board_id in ("b0", "b1", "b2"):
        write_instance(base_board(), root / "d2" / "test" / board_id)
    return seal_set(root)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    runs = tmp_path_factory.mktemp("runs") / "router"
    clean = routed(base_board(), [ROUTE_A, ROUTE_B])
    times = {"0": -1, "1": True, "2": 1e308, "3": 2.5}  # only 2.5 s is a time
    for rollout, seconds in times.items():
        write_board(clean, runs / "b0" / f"{rollout}.kicad_pcb")
        (runs / "b0" / f"{rollout}.json").write_text(json.dumps({"time_s": seconds}))
    write_board(clean, runs / "b1" / "0.kicad_pcb")
    (runs / "b1" / "0.json").write_text("[" * 100_000 + "]" * 100_000)  # deeper than json reads
    write_board(clean, runs / "b2" / "0.kicad_pcb")
    (runs / "b2" / "0.json").write_text(json.dumps({"seconds": "12"}))
    (runs / "b2" / "notes.txt").write_text("x")
    write_board(clean, runs / "b7" / "0.kicad_pcb")  # boards that are not in the split
    write_board(clean, runs / "board_00042" / "0.kicad_pcb")
    return runs


def read_csv(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def run_main(args, capsys):
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr()


BAD = [
    (["--limit", "-3"], "argument --limit: must be an integer >= 1"),
    (["--limit", "0"], "argument --limit: must be an integer >= 1"),
    (["--timeout", "0"], "argument --timeout: must be a finite number > 0"),
    (["--timeout", "inf"], "argument --timeout"),
    (["--lw", "nan"], "argument --lw: must be a finite number >= 0"),
    (["--lv", "nan"], "argument --lv"),
    (["--lv", "-0.1"], "argument --lv"),
    (["--k", "0"], "argument --k: must be an integer >= 1"),
    (["--workers", "0"], "argument --workers"),
    (["--name", "a|b"], "--name 'a|b'"),
]


@pytest.mark.parametrize("options, message", BAD, ids=[" ".join(o) for o, _ in BAD])
def test_bad_options_are_one_line_and_write_nothing(board_set, runs, tmp_path, capsys,
                                                    options, message):
    out = tmp_path / "report"
    code, captured = run_main(["eval", board_set, "--config", "d2", "--runs", runs, "--out", out,
                               *options], capsys)
    lines = captured.err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("pcbdata: error: "), captured.err
    assert message in lines[0]
    assert not out.exists()


def test_out_that_is_a_file(board_set, runs, tmp_path, capsys):
    report = tmp_path / "report.txt"
    report.write_text("keep me")
    code, captured = run_main(["eval", board_set, "--config", "d2", "--runs", runs,
                               "--out", report], capsys)
    assert code == 2 and captured.err.strip().splitlines() == [
        f"pcbdata: error: --out {report}: exists and is not a folder (REPORT is a folder)"]
    assert report.read_text() == "keep me"


def test_api_checks_its_arguments(board_set, runs, tmp_path):
    for kwargs, message in (({"limit": -3}, "--limit"), ({"limit": 0}, "--limit"),
                            ({"task_timeout": 0.0}, "--timeout"), ({"k": 0}, "--k"),
                            ({"workers": 0}, "--workers")):
        with pytest.raises(UserError, match=message):
            evaluate_set(board_set, "d2", "test", tmp_path / "r", runs=runs, **kwargs)
    assert not (tmp_path / "r").exists()


def test_sidecar_times_are_validated(tmp_path):
    from pcbdata.evaluator.runs import read_rollout_time

    board = tmp_path / "0.kicad_pcb"
    for content, time_s, reason in (
            ({"time_s": 3}, 3.0, ""), ({"time": 0}, 0.0, ""), ({"note": 1}, None, ""),
            ({"time_s": None, "seconds": 4}, 4.0, ""),
            ({"time_s": -1}, None, "invalid time_s -1"),
            ({"time_s": True}, None, "invalid time_s True"),
            ({"time_s": 1e308}, None, "invalid time_s 1e+308"),
            ({"seconds": "12"}, None, "invalid seconds '12'"),
            ({"time_s": [1]}, None, "invalid time_s list"),
            ([1, 2], None, "not a JSON object")):
        (tmp_path / "0.json").write_text(json.dumps(content))
        seconds, problem = read_rollout_time(board)
        assert seconds == time_s and (reason in problem if reason else problem == ""), content
    (tmp_path / "0.json").write_text("[" * 50_000)
    assert read_rollout_time(board) == (None, "0.json: JSON nested too deeply to read")
    (tmp_path / "0.json").write_bytes(b'{"time_s": 1, "x": "\xff"}')
    assert read_rollout_time(board) == (None, "0.json: not UTF-8 text")


def test_bad_sidecars_and_stray_runs_are_recorded_and_the_report_written(
        board_set, runs, tmp_path, capsys):
    out = tmp_path / "report"
    code, captured = run_main(["eval", board_set, "--config", "d2", "--runs", runs, "--out", out,
                               "--workers", "2"], capsys)
    assert code == 0, captured.err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_boards"] == 3 and summary["cp"] == 1.0
    assert summary["time"] == 2.5  # the one valid time; -1, true, 1e308 and "12" not counted
    warnings = summary["runs_warnings"]
    assert warnings["not_in_split"] == ["b7", "board_00042"]
    assert warnings["not_a_rollout"] == ["b2/notes.txt"]
    bad = {(w["board_id"], w["rollout"]): w["reason"] for w in warnings["invalid_times"]}
    assert sorted(bad) == [("b0", "0"), ("b0", "1"), ("b0", "2"), ("b1", "0"), ("b2", "0")]
    assert bad[("b1", "0")] == "0.json: JSON nested too deeply to read"
    assert "invalid time_s True" in bad[("b0", "1")]
    times = {(r["board_id"], r["rollout"]): r["time"] for r in read_csv(out / "per_rollout.csv")}
    assert times == {("b0", "0"): "", ("b0", "1"): "", ("b0", "2"): "", ("b0", "3"): "2.5",
                     ("b1", "0"): "", ("b2", "0"): ""}
    warned = [line for line in captured.err.splitlines() if "warning" in line]
    assert any("not boards of this split" in line and "b7; board_00042" in line
               for line in warned), captured.err
    assert any("rollout times not valid" in line and "b1/0" in line for line in warned)


def test_limit_scores_the_first_boards_and_does_not_warn_about_the_rest(
        board_set, runs, tmp_path, capsys):
    out = tmp_path / "report"
    code, captured = run_main(["eval", board_set, "--config", "d2", "--runs", runs, "--out", out,
                               "--limit", "2", "--k", "1", "--workers", "2"], capsys)
    assert code == 0, captured.err
    assert [r["board_id"] for r in read_csv(out / "per_board.csv")] == ["b0", "b1"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs_warnings"]["not_in_split"] == ["b7", "board_00042"]  # not b2
    assert summary["runs_warnings"]["beyond_k"] == ["b0/1", "b0/2", "b0/3"]

"""`pcbdata eval` end to end on a tiny hand-made set: @k, ties, bad files, reports, resume."""
from __future__ import annotations

import csv
import json
import shutil

import pytest
from boards import ROUTE_A, ROUTE_B, base_board, pad, routed, track, write_board, write_instance

from pcbdata.cli import main
from pcbdata.testing.sets import seal_set


@pytest.fixture(scope="module")
def board_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("set")
    for board_id in ("b0", "b1", "b2", "b3"):
        write_instance(base_board(), root / "d2" / "test" / board_id)
    return seal_set(root)


@pytest.fixture(scope="module")
def runs(board_set, tmp_path_factory):
    runs = tmp_path_factory.mktemp("runs") / "my-router"
    clean = routed(base_board(), [ROUTE_A, ROUTE_B])
    # b0: two identical clean rollouts (a tie: rollout 0 is kept) and a half-routed one
    write_board(routed(base_board(), [ROUTE_A]), runs / "b0" / "0.kicad_pcb")
    write_board(clean, runs / "b0" / "1.kicad_pcb")
    shutil.copy(runs / "b0" / "1.kicad_pcb", runs / "b0" / "2.kicad_pcb")
    for i, seconds in enumerate((1.0, 2.0, 3.0)):
        (runs / "b0" / f"{i}.json").write_text(json.dumps({"time_s": seconds, "note": "x"}))
    # b1: nothing loads (empty, truncated, no board at all) -> Parse-fail, CP 0, Rout. 0
    (runs / "b1").mkdir()
    (runs / "b1" / "0.kicad_pcb").write_text("")
    text = (runs / "b0" / "1.kicad_pcb").read_text()
    (runs / "b1" / "1.kicad_pcb").write_text(text[: len(text) // 3])
    (runs / "b1" / "2.json").write_text(json.dumps({"time_s": 5.0}))  # a rollout with no board
    (runs / "b1" / "3.kicad_pcb").write_text("{\"not\": \"a board\"}")  # beyond k = 3
    # b2: an invalid rollout (a pad moved), two dangling-track ones, a clean one named 10
    # (natural order puts it 4th, beyond k = 3)
    moved = routed(base_board(pads=[pad(11, 10, "A")] + base_board().pads[1:]), [ROUTE_A, ROUTE_B])
    write_board(moved, runs / "b2" / "1.kicad_pcb")
    write_board(routed(base_board(), [ROUTE_A, ROUTE_B, track(30, 10, 30, 20, "A")]),
                runs / "b2" / "2.kicad_pcb")
    shutil.copy(runs / "b2" / "2.kicad_pcb", runs / "b2" / "3.kicad_pcb")
    write_board(clean, runs / "b2" / "10.kicad_pcb")
    # b3: no submission at all
    return runs


def read_csv(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_eval_reports(board_set, runs, tmp_path, capsys):
    out = tmp_path / "report"
    args = [ "eval", str(board_set), "--config", "d2", "--split", "test", "--runs", str(runs),
            "--out", str(out), "--workers", "2"]
    assert main(args + ["--k", "3"]) == 0
    printed = capsys.readouterr().out
    assert "| my-router |" in printed
    summary = json.loads((out / "summary.json").read_text())
    for key in ("n_boards", "k", "cp", "pot", "pot_evaluation", "rout", "drv", "wl", "via", "time",
                "parse_fail",
                "parse_fail_at1", "invalid"):
        assert key in summary
    assert summary["n_boards"] == 4 and summary["k"] == 3
    boards = {row["board_id"]: row for row in read_csv(out / "per_board.csv")}
    assert boards["b0"]["best_rollout"] == "1"  # ties with 2, lower index wins
    assert boards["b0"]["cp"] == "1" and boards["b0"]["time"] == "2.0"
    assert boards["b1"]["parse_fail"] == "1" and boards["b1"]["cp"] == "0"
    assert boards["b1"]["rout"] == "0.0"
    assert boards["b2"]["best_rollout"] == "2" and boards["b2"]["cp"] == "1"  # tie with 3
    # b2's dangling track is a warning: in the strict count only (CP+, DRV+)
    assert (boards["b2"]["cp_strict"], boards["b2"]["drv_strict"]) == ("0", "1")
    assert boards["b3"]["parse_fail"] == "1"
    rollouts = read_csv(out / "per_rollout.csv")
    assert len(rollouts) == 3 + 3 + 3 + 1
    by = {(r["board_id"], r["rollout"]): r for r in rollouts}
    assert by[("b1", "0")]["reason"] == "empty file"
    assert by[("b1", "1")]["status"] == "parse_fail" and by[("b1", "1")]["reason"]
    assert by[("b1", "2")]["reason"] == "missing file" and by[("b1", "2")]["time"] == "5.0"
    assert ("b1", "3") not in by  # beyond k = 3
    b2_rollout = by[("b2", "1")]
    assert b2_rollout["status"] == "invalid" and "footprints changed" in b2_rollout["reason"]
    assert by[("b3", "missing")]["reason"] == "missing file"
    assert summary["cp"] == pytest.approx(0.5) and summary["cp_strict"] == pytest.approx(0.25)
    assert summary["rout"] == pytest.approx(0.5)  # b0 1, b2 1, b1 and b3 count 0
    assert summary["parse_fail"] == pytest.approx(0.5)
    assert summary["parse_fail_at1"] == pytest.approx(4 / 10)
    assert summary["invalid"] == pytest.approx(1 / 10)
    assert summary["time"] == pytest.approx((1 + 2 + 3 + 5) / 4)  # every rollout's time
    assert summary["drv"] == 0.0 and summary["drv_strict"] == pytest.approx(0.5)
    md = (out / "summary.md").read_text()
    assert ("| Method | CP (%) | Pot. | Rout. | DRV | WL (mm) | Via | Time (s) | "
            "CP+ (%) | DRV+ |") in md

    # resumable: a second run scores nothing again and gives the same reports
    before = (out / "scores.jsonl").read_text()
    assert main(args + ["--k", "3"]) == 0
    assert "0 to score" in capsys.readouterr().err
    assert (out / "scores.jsonl").read_text() == before
    assert json.loads((out / "summary.json").read_text()) == summary

    # @1 keeps the first rollout only
    assert main(args + ["--k", "1"]) == 0
    s1 = json.loads((out / "summary.json").read_text())
    assert s1["k"] == 1 and s1["n_rollouts"] == 4 and s1["cp"] == 0.0


def test_eval_reference(board_set, tmp_path, capsys):
    root = tmp_path / "set"
    shutil.copytree(board_set, root)
    for folder in (root / "d2" / "test").iterdir():
        write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), folder / "reference.kicad_pcb")
    seal_set(root)
    out = tmp_path / "ref"
    assert main(["eval", str(root), "--config", "d2", "--reference", "--out", str(out)]) == 0
    assert "| Reference |" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cp"] == 1.0 and summary["k"] == 1 and summary["n_boards"] == 4
    assert main(["eval", str(root), "--config", "d2", "--reference", "--out", str(out),
                 "--limit", "2"]) == 0
    assert json.loads((out / "summary.json").read_text())["n_boards"] == 2


def test_eval_user_errors(board_set, runs, tmp_path, capsys):
    assert main(["eval", str(board_set), "--config", "nope", "--runs", str(runs),
                 "--out", str(tmp_path / "r")]) == 2
    assert "no such config/split" in capsys.readouterr().err
    assert main(["eval", str(board_set), "--config", "d2", "--reference",
                 "--out", str(tmp_path / "r")]) == 2
    assert "reference.kicad_pcb" in capsys.readouterr().err
    assert main(["eval", str(board_set), "--config", "d2", "--out", str(tmp_path / "r")]) == 2


def test_a_config_the_set_lacks_is_answered_with_the_configs_its_manifest_holds(tmp_path,
                                                                                 capsys):
    """A set `pcbdata build d2` wrote also holds .pcbdata/ and pictures/: not configs."""
    built = tmp_path / "d2"
    assert main(["build", "d2", "--out", str(built), "--splits", "test", "--count", "2",
                 "--no-check", "--workers", "1"]) == 0
    assert (built / ".pcbdata").is_dir() and (built / "pictures").is_dir()
    capsys.readouterr()
    runs = tmp_path / "runs"
    runs.mkdir()
    assert main(["eval", str(built), "--config", "d3-a", "--runs", str(runs),
                 "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.strip().endswith(f"no such config/split in {built} (configs: d2)"), err
    assert main(["eval", str(built), "--config", "d2", "--split", "train", "--runs", str(runs),
                 "--out", str(tmp_path / "r")]) == 2
    assert capsys.readouterr().err.strip().endswith("(d2 has splits: test)")


def test_line_ends_kicad_loads_are_scored_and_a_byte_order_mark_is_refused_with_the_reason(
        board_set, tmp_path, capsys, kicad_pool):
    """KiCad 9.0.8 loads a board with CRLF or CR line ends and refuses one that starts with a
    byte-order mark (checked here in KiCad itself); eval does the same and says why."""
    lf = write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), tmp_path / "lf.kicad_pcb")
    text, bom = lf.read_bytes(), b"\xef\xbb\xbf"
    variants = {"b0": text.replace(b"\n", b"\r\n"), "b1": bom + text.replace(b"\n", b"\r\n"),
                "b2": bom + text, "b3": text.replace(b"\n", b"\r")}
    runs = tmp_path / "runs"
    for board_id, data in variants.items():
        (runs / board_id).mkdir(parents=True)
        (runs / board_id / "0.kicad_pcb").write_bytes(data)
    loads = {b: kicad_pool.call("boards:kicad_loads", str(runs / b / "0.kicad_pcb"))
             for b in variants}
    assert loads == {"b0": True, "b1": False, "b2": False, "b3": True}
    out = tmp_path / "report"
    assert main(["eval", str(board_set), "--config", "d2", "--runs", str(runs), "--out",
                 str(out), "--k", "1", "--workers", "2"]) == 0, capsys.readouterr().err
    by = {r["board_id"]: r for r in read_csv(out / "per_rollout.csv")}
    assert [(by[b]["status"], by[b]["cp"]) for b in ("b0", "b3")] == [("ok", "1"), ("ok", "1")]
    for board_id in ("b1", "b2"):
        assert by[board_id]["status"] == "parse_fail", by[board_id]
        assert by[board_id]["reason"].startswith("starts with a UTF-8 byte-order mark, which "
                                                 "KiCad 9.0.8 does not load"), by[board_id]

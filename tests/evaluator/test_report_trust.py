"""Reports that can be trusted: the set a report scored is
named and checked, the score cache is never taken on faith, and the gaps that moved a set's
figures without a word (missing times, boards without a scored rollout, huge files, odd file
names, a REPORT folder inside the inputs) are closed. Real KiCad throughout."""
from __future__ import annotations

import json
import shutil

import pytest
from boards import ROUTE_A, ROUTE_B, base_board, routed, write_board, write_instance

from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.evaluator.runs import CACHE_NAME, evaluate_set
from pcbdata.sets.configs import get_config
from pcbdata.testing.sets import seal_set

BOARDS = ("b0", "b1", "b2", "b3")


@pytest.fixture(scope="module")
def board_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("set")
    for board_id in BOARDS:
        write_instance(base_board(), root / "d2" / "test" / board_id)
    return seal_set(root)


@pytest.fixture
def runs(tmp_path):
    """Every board routed clean (rollout 0, 2 s) and half routed (rollout 1, 1 s)."""
    runs = tmp_path / "runs" / "method"
    for board_id in BOARDS:
        write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), runs / board_id / "0.kicad_pcb")
        write_board(routed(base_board(), [ROUTE_A]), runs / board_id / "1.kicad_pcb")
        for rollout, seconds in ((0, 2.0), (1, 1.0)):
            (runs / board_id / f"{rollout}.json").write_text(json.dumps({"time_s": seconds}))
    return runs


def evaluate(board_set, runs, out, **options):
    return evaluate_set(board_set, "d2", "test", out, runs=runs, k=2, workers=2, progress=False,
                        **options)


def test_the_report_names_the_set_it_scored(board_set, runs, tmp_path):
    result = evaluate(board_set, runs, tmp_path / "report")
    identity = result["summary"]["set"]
    assert identity["config"] == "d2" and identity["split"] == "test"
    assert identity["set_version"] == get_config("d2").version and identity["verified"] is True
    assert len(identity["manifest_sha256"]) == 64
    assert identity["release"] == "differs"  # hand-made boards are not the released d2
    text = (tmp_path / "report" / "summary.md").read_text()
    assert f"manifest sha256 {identity['manifest_sha256']}" in text and "release: differs" in text


def test_a_released_subset_matches_its_release(tmp_path):
    built = tmp_path / "built"
    assert main(["build", "d2", "--splits", "test", "--count", "2", "--no-check", "--out",
                 str(built), "--workers", "1"]) == 0
    runs = tmp_path / "runs"
    for board in (built / "d2" / "test").iterdir():  # the bare boards: nothing routed
        (runs / board.name).mkdir(parents=True)
        shutil.copy(board / "board.kicad_pcb", runs / board.name / "0.kicad_pcb")
    result = evaluate_set(built, "d2", "test", tmp_path / "report", runs=runs, k=1,
                          progress=False)
    s = result["summary"]
    assert (s["set"]["release"], s["set"]["verified"]) == ("matches", True)
    assert s["pot"] == 0.0 and s["cp"] == 0.0


def test_an_edited_set_is_refused_or_marked(board_set, runs, tmp_path, capsys):
    edited = tmp_path / "edited"
    shutil.copytree(board_set, edited)
    board = edited / "d2" / "test" / "b1" / "board.kicad_pcb"
    board.write_text(board.read_text().replace("(at 10 10)", "(at 11 10)", 1))
    with pytest.raises(UserError, match=r"d2/test/b1/board.kicad_pcb: altered"):
        evaluate(edited, runs, tmp_path / "refused")
    assert not (tmp_path / "refused").exists()
    code = main(["eval", str(edited), "--config", "d2", "--runs", str(runs), "--out",
                 str(tmp_path / "marked"), "--k", "2", "--workers", "2", "--allow-unverified"])
    assert code == 0
    assert "| method (unverified set) |" in capsys.readouterr().out
    identity = json.loads((tmp_path / "marked" / "summary.json").read_text())["set"]
    assert identity["verified"] is False and identity["n_problems"] == 1
    assert "NOT VERIFIED" in (tmp_path / "marked" / "summary.md").read_text()


def test_an_edited_cache_record_is_scored_again(board_set, runs, tmp_path, capsys):
    out = tmp_path / "report"
    honest = evaluate(board_set, runs, out)["summary"]
    lines = (out / CACHE_NAME).read_text().splitlines()
    forged = []
    for number, line in enumerate(lines):  # Pot. 99 written in, or the counts under it edited
        entry = json.loads(line)
        if number % 2:
            entry["record"]["pot"] = 99
        else:
            entry["record"]["raw"]["routed"]["wl"] = 0.0
        forged.append(json.dumps(entry))
    (out / CACHE_NAME).write_text("\n".join(forged) + "\n")
    again = evaluate_set(board_set, "d2", "test", out, runs=runs, k=2, workers=2)["summary"]
    assert again["pot"] == pytest.approx(honest["pot"]) and again["wl"] == honest["wl"]
    assert again["cache"] == {"used": True, "tampered": len(lines)}
    assert "do not match their digest" in capsys.readouterr().err
    fresh = evaluate(board_set, runs, out, use_cache=False)["summary"]
    assert fresh["cache"] == {"used": False, "tampered": 0}
    assert {k: v for k, v in fresh.items() if k != "cache"} == \
        {k: v for k, v in honest.items() if k != "cache"}


def test_a_board_without_a_scored_rollout_counts_as_its_bare_board(board_set, runs, tmp_path):
    honest = evaluate(board_set, runs, tmp_path / "honest")["summary"]
    for board_id in ("b2", "b3"):  # the two "worst" boards emptied
        shutil.rmtree(runs / board_id)
    emptied = evaluate(board_set, runs, tmp_path / "emptied")["summary"]
    assert emptied["pot"] == pytest.approx(honest["pot"] / 2)  # Pot. 0 for each, not left out
    assert (emptied["cp"], emptied["rout"]) == (0.5, 0.5)
    assert emptied["n_boards_scored"] == 2 and emptied["wl"] == honest["wl"]


def test_missing_times_are_counted_and_warned(board_set, runs, tmp_path, capsys):
    for board_id in BOARDS:  # the slow rollouts' sidecars deleted: Time would drop silently
        (runs / board_id / "0.json").unlink()
    s = evaluate_set(board_set, "d2", "test", tmp_path / "report", runs=runs, k=2, workers=2)
    s = s["summary"]
    assert (s["time"], s["n_timed"], s["n_rollouts"]) == (1.0, 4, 8)
    assert s["runs_warnings"]["untimed"] == [f"{b}/0" for b in BOARDS]
    err = capsys.readouterr().err
    assert "rollouts without a time while others have one" in err
    assert "8 rollouts (4 with a time)" in (tmp_path / "report" / "summary.md").read_text()


def test_a_huge_file_is_refused_before_loading(board_set, runs, tmp_path):
    from pcbdata.evaluator.scorer import MIN_SIZE_LIMIT

    huge = runs / "b0" / "1.kicad_pcb"
    text = huge.read_text()
    padding = " " * (MIN_SIZE_LIMIT + 1)
    huge.write_text(text.replace("(kicad_pcb", "(kicad_pcb" + padding, 1))
    rows = {(r["board_id"], r["rollout"]): r
            for r in evaluate(board_set, runs, tmp_path / "report")["rollouts"]}
    row = rows[("b0", "1")]
    assert row["status"] == "invalid"
    assert f"file of {huge.stat().st_size} bytes is above the limit of {MIN_SIZE_LIMIT}" \
        in row["reason"]


def test_odd_file_names_stay_on_one_warning_line(board_set, runs, tmp_path, capsys):
    (runs / "b0" / "a\nb.txt").write_text("x")
    evaluate_set(board_set, "d2", "test", tmp_path / "report", runs=runs, k=2, workers=2)
    line = next(x for x in capsys.readouterr().err.splitlines() if "not rollouts" in x)
    assert '"b0/a\\nb.txt"' in line


def test_a_report_inside_the_inputs_is_refused(board_set, runs, tmp_path):
    for inside in (board_set / "report", runs / "report", runs):
        with pytest.raises(UserError, match="inside"):
            evaluate(board_set, runs, inside)
        assert not (inside / "summary.json").exists()

"""Files that hang KiCad's parser are refused before KiCad sees them, and a time limit that
was hit is remembered (by file hash and limits) so a re-run does not pay for it again."""
from __future__ import annotations

import csv
import json
import shutil
import time
from pathlib import Path

import pytest

from pcbdata.cli import main
from pcbdata.core.sexpr_text import cut_problem
from pcbdata.model.kicad_writer import board_text
from pcbdata.testing.sets import seal_set
from tests.evaluator.boards import (
    ROUTE_A,
    ROUTE_B,
    base_board,
    routed,
    track,
    write_board,
    write_instance,
)


def cut_in_pad_layers(text: str) -> str:
    """The board cut just after `(layers "F.Cu" ` of its first pad: KiCad 9.0.8's parser spins
    on this until the time limit instead of failing."""
    start = text.index("(layers", text.index("(pad"))
    return text[: start + len('(layers "F.Cu" ')]


def routed_text() -> str:
    return board_text(routed(base_board(), [ROUTE_A, ROUTE_B]))


@pytest.mark.parametrize("text, problem", [
    ('(kicad_pcb (a "x") (b))\n', None),
    ('(kicad_pcb (a "with \\" quote ( and paren") (b "back\\\\"))', None),  # KiCad's escapes
    ('(kicad_pcb (a "unclosed (b))', "quoted string is not closed"),
    ("(kicad_pcb (a (b)", "2 parentheses are not closed"),
    ("(kicad_pcb (a)))", "closes nothing"),
    ("(kicad_pcb (a)) (b)", "text after the end"),
    ("(kicad_pcb (a)) trailing", "text after the end"),
    ("kicad_pcb", "no parentheses"),
])
def test_cut_problem(text, problem):
    found = cut_problem(text.encode())
    assert (found is None) if problem is None else (problem in found)


def test_whole_boards_pass_and_cut_ones_do_not():
    from tests.curation.corpus_fixture import legacy_board_text

    text = routed_text()
    assert cut_problem(text.encode()) is None
    assert cut_problem(legacy_board_text().encode()) is None  # KiCad 5 syntax
    assert "not closed" in cut_problem(cut_in_pad_layers(text).encode())
    assert all(cut_problem(text[:n].encode()) for n in range(1, len(text) - 2, 97))


@pytest.fixture
def one_board_set(tmp_path):
    root = tmp_path / "set"
    write_instance(base_board(), root / "d2" / "test" / "b0")
    return seal_set(root)


def eval_args(root: Path, runs: Path, out: Path, timeout: float) -> list[str]:
    return ["eval", str(root), "--config", "d2", "--runs", str(runs), "--out", str(out),
            "--workers", "1", "--k", "1", "--timeout", f"{timeout:g}"]


def rollout_rows(out: Path) -> list[dict]:
    with open(out / "per_rollout.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def test_eval_refuses_a_cut_board_before_kicad_hangs_on_it(one_board_set, tmp_path):
    runs = tmp_path / "runs"
    (runs / "b0").mkdir(parents=True)
    (runs / "b0" / "0.kicad_pcb").write_text(cut_in_pad_layers(routed_text()))
    start = time.monotonic()
    assert main(eval_args(one_board_set, runs, tmp_path / "report", timeout=20)) == 0
    assert time.monotonic() - start < 20  # not the time limit
    [row] = rollout_rows(tmp_path / "report")
    assert row["status"] == "parse_fail" and row["reason"].startswith("truncated or malformed file")


def dense_board():
    """500 x 500 crossing tracks of two nets: KiCad's DRC needs about 40 s on it."""
    tracks = [track(5, 5 + 30 * i / 500, 55, 5 + 30 * i / 500, "A") for i in range(500)]
    tracks += [track(5 + 50 * i / 500, 5, 5 + 50 * i / 500, 35, "B") for i in range(500)]
    return routed(base_board(), tracks)


def test_eval_caches_a_time_out_under_its_limits(one_board_set, tmp_path, capsys):
    runs = tmp_path / "runs"
    write_board(dense_board(), runs / "b0" / "0.kicad_pcb")
    out = tmp_path / "report"
    # The dense board takes about 10 s to score on an idle 2-core machine: both limits are
    # well below it, and short, since the test waits for them.
    assert main(eval_args(one_board_set, runs, out, timeout=4)) == 0
    [row] = rollout_rows(out)
    assert row["reason"] == "engine failure: time limit of 4 s exceeded"
    capsys.readouterr()

    start = time.monotonic()  # same file, same limit: not run again
    assert main(eval_args(one_board_set, runs, out, timeout=4)) == 0
    assert "1 cached, 0 to score" in capsys.readouterr().err
    assert time.monotonic() - start < 4
    assert rollout_rows(out) == [row]

    assert main(eval_args(one_board_set, runs, out, timeout=5)) == 0  # another limit: run
    assert "0 cached, 1 to score" in capsys.readouterr().err
    assert rollout_rows(out)[0]["reason"] == "engine failure: time limit of 5 s exceeded"


def test_d3_build_gives_a_cut_board_its_load_failure_without_kicad(tmp_path):
    from pcbdata.build.d3 import build
    from pcbdata.sets.recipe import load_recipe
    from tests.curation.corpus_fixture import fixture_recipe, make_corpus

    make_corpus(tmp_path / "corpus")
    folder = tmp_path / "src" / "PCBs" / "zulu_cut"
    shutil.copytree(tmp_path / "corpus" / "PCBs" / "alpha", folder)
    board = folder / "processed.kicad_pcb"
    board.write_text(cut_in_pad_layers(board.read_text()))
    recipe = fixture_recipe(tmp_path / "recipe.toml")
    recipe.write_text(recipe.read_text().replace("task_timeout_s = 120", "task_timeout_s = 30"))
    lines: list[str] = []
    summary = build(tmp_path / "src", tmp_path / "out", load_recipe(recipe), workers=1,
                    log=lines.append)
    assert summary["fates"]["load_failure"] == 1
    assert any("0 to process" in line for line in lines)
    report = json.loads((tmp_path / "out" / "curation_report.json").read_text())
    [entry] = report["boards"]
    assert entry["fate"] == "load_failure"
    assert entry["reason"].startswith("load: truncated or malformed file")

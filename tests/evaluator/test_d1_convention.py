"""The published D1 convention (`pcbdata eval --convention d1-published`, SPEC 4): no WL or via
term and Phi(bare) = -U0, pinned on its two anchors and on a board with one open net, through
the CLI, with the convention recorded in the report."""
from __future__ import annotations

import json
import math
from dataclasses import replace

import pytest
from boards import write_board, write_instance

from pcbdata.cli import main
from pcbdata.evaluator.metrics import CONVENTIONS
from pcbdata.testing.sets import seal_set

CLEAN = math.log(7) + 5  # ln(1 + N), N = 6 (five nets and the unconnected net), minus -U0
UNTOUCHED = -(3 * math.log(3.5) + 5 * math.log(1.5))  # -f0: five nets with one open edge each
ONE_OPEN = 4 - (3 * math.log(1.5) + math.log(1.5))  # Phi = -1 - f (one net hit), minus -5


@pytest.fixture(scope="module")
def d1_runs(tmp_path_factory):
    """A D1-10 set of one random-walk board (its walks are a clean, complete routing) and a
    runs folder: the complete routing, the bare board, and the routing without one net."""
    from pcbdata.generators.d1 import D1Generator, D1Params

    inst = D1Generator(D1Params(grid=10, placement="random-walk")).generate(0, "test", 0)
    root = tmp_path_factory.mktemp("d1set")
    write_instance(inst.board, root / "d1-g10" / "test" / inst.board_id)
    seal_set(root)
    runs = tmp_path_factory.mktemp("runs") / "walks"
    folder = runs / inst.board_id
    write_board(inst.reference, folder / "0.kicad_pcb")
    write_board(inst.board, folder / "1.kicad_pcb")
    open_net = inst.reference.tracks[0].net
    tracks = [t for t in inst.reference.tracks if t.net != open_net]
    write_board(replace(inst.reference, tracks=tracks), folder / "2.kicad_pcb")
    return root, runs


def _evaluate(root, runs, out, *extra):
    assert main(["eval", str(root), "--config", "d1-g10", "--runs", str(runs), "--k", "3",
                 "--out", str(out), "--workers", "2", *extra]) == 0
    with open(out / "per_rollout.csv", encoding="utf-8") as handle:
        header, *rows = [line.rstrip("\n").split(",") for line in handle]
    pot = header.index("pot")
    summary = json.loads((out / "summary.json").read_text())
    return [float(r[pot]) for r in rows], summary


def test_d1_published_convention_anchors(d1_runs, tmp_path):
    root, runs = d1_runs
    pots, summary = _evaluate(root, runs, tmp_path / "published", "--convention", "d1-published")
    assert pots == pytest.approx([CLEAN, UNTOUCHED, ONE_OPEN], abs=1e-9)
    assert round(CLEAN, 3) == 6.946 and round(UNTOUCHED, 3) == -5.786
    assert summary["convention"] == "d1-published"
    assert summary["weights"] == {"lw": 0.0, "lv": 0.0, "net_weight": 3.0, "bare_drc": False}
    assert "scoring convention d1-published" in (tmp_path / "published" / "summary.md").read_text()


def test_default_convention_is_the_spec_formula(d1_runs, tmp_path):
    """The same boards under SPEC 4's formula: the published figures are ours with weights 0
    minus the bare board's DRC term (5.786)."""
    root, runs = d1_runs
    pots, summary = _evaluate(root, runs, tmp_path / "spec")
    assert summary["convention"] == "spec"
    assert pots[1] == pytest.approx(0.0, abs=1e-9)
    assert CONVENTIONS["spec"].bare_drc
    weighted, _ = _evaluate(root, runs, tmp_path / "zero", "--lw", "0", "--lv", "0")
    assert weighted == pytest.approx([p - UNTOUCHED for p in (CLEAN, UNTOUCHED, ONE_OPEN)])
    assert pots[0] < weighted[0]  # the WL term counts by default


def test_convention_fixes_its_weights(d1_runs, tmp_path, capsys):
    root, runs = d1_runs
    code = main(["eval", str(root), "--config", "d1-g10", "--runs", str(runs), "--out",
                 str(tmp_path / "r"), "--convention", "d1-published", "--lw", "0.01"])
    assert code == 2
    assert "--convention d1-published fixes the weights; drop --lw" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()

"""`pcbdata rollout` end to end on a few D2 boards, then `pcbdata eval` on its output."""
from __future__ import annotations

import json

from pcbdata import __version__
from pcbdata.cli import main


def test_rollout_then_eval(board_set, tmp_path, capsys):
    runs = tmp_path / "runs"
    argv = ["rollout", str(board_set), "--config", "d2", "--split", "test", "--agent",
            "pcbdata.agents.random:RandomAgent", "--rollouts", "2", "--limit", "2",
            "--max-steps", "15", "--workers", "2", "--out", str(runs)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "done: 4 rollouts run, 0 already done" in printed and "[4/4]" in printed
    for board in ("board_00000", "board_00001"):
        for rollout in (0, 1):
            record = json.loads((runs / board / f"{rollout}.json").read_text())
            assert record["steps"] == 15 and record["time_s"] > 0
            assert (runs / board / f"{rollout}.kicad_pcb").is_file()
            assert record["seed"] == rollout and record["env_version"] == 2
            assert record["budgets"] == {"max_steps": 15, "step_limit": 15, "drc": "step",
                                         "time_limit_s": 3600.0}
            assert record["agent_identity"]["name"] == "pcbdata.agents.random:RandomAgent"
            assert record["agent_identity"]["version"] == __version__
            assert record["machine"]["cores"] >= 1
    assert main(argv) == 0  # resumable: nothing left to run
    assert "nothing to run (4 already done)" in capsys.readouterr().out
    report = tmp_path / "report"
    assert main(["eval", str(board_set), "--config", "d2", "--split", "test", "--runs",
                 str(runs), "--out", str(report), "--k", "2", "--workers", "1"]) in (0, 1)
    rows = (report / "per_rollout.csv").read_text().splitlines()
    assert len(rows) >= 5 and all(",ok," in row for row in rows[1:5])
    results = json.loads((report / "results.json").read_text())  # what results.json needs
    assert results["agent"]["name"] == "pcbdata.agents.random:RandomAgent"
    assert results["seeds"] == [0, 1] and results["env_id"]["version"] == 2
    assert results["budgets"] == {"k": 2, "max_steps": 15, "drc": "step", "time_limit_s": 3600.0}


def test_rollout_bad_agent_is_a_user_error(board_set, tmp_path, capsys):
    argv = ["rollout", str(board_set), "--config", "d2", "--agent", "nosuch:Agent",
            "--out", str(tmp_path / "r")]
    assert main(argv) == 2
    assert "pcbdata: error: --agent" in capsys.readouterr().err


def test_a_rollout_whose_worker_dies_is_reported_and_left_pending(board_set, tmp_path, capsys):
    runs = tmp_path / "runs"
    argv = ["rollout", str(board_set), "--config", "d2", "--agent",
            "tests.env.agents_for_tests:CrashingAgent", "--limit", "1", "--workers", "1",
            "--out", str(runs)]
    assert main(argv) == 3
    captured = capsys.readouterr()
    assert "board_00000 #0: failed: worker" in captured.out
    assert "1 rollouts failed" in captured.err
    assert not (runs / "board_00000" / "0.json").exists()  # pending: the next run retries it


def test_rollout_unknown_config_names_the_configs_of_the_set(board_set, tmp_path, capsys):
    argv = ["rollout", str(board_set), "--config", "d2-hardd", "--out", str(tmp_path / "r")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "did you mean 'd2'" in err and "it holds: d1-g10, d2" in err

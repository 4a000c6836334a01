"""`pcbdata rollout --executor ray`: the same files as the local executor, byte for
byte but for the wall time `time_s`, on the 2-CPU local Ray cluster; a rollout whose Ray worker
dies mid-episode is run again and loses nothing."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from pcbdata.cli import main

#: The JSON fields that are wall-clock measurements or the machine's state (its load), hence
#: differ run to run (and worker to worker) whatever the executor; every other byte of every
#: file must be the same.
WALL_CLOCK = ("time_s", "machine")


def _outputs(runs: Path) -> dict[str, object]:
    """Every file under RUNS: `.kicad_pcb` as bytes, `.json` parsed without the wall times."""
    out: dict[str, object] = {}
    for path in sorted(runs.rglob("*")):
        if not path.is_file():
            continue
        name = str(path.relative_to(runs))
        if path.suffix == ".json":
            record = json.loads(path.read_text())
            assert record["time_s"] > 0
            out[name] = {k: v for k, v in record.items() if k not in WALL_CLOCK}
        else:
            out[name] = path.read_bytes()
    return out


def _rollout(board_set: Path, runs: Path, *extra: str) -> int:
    return main(["rollout", str(board_set), "--config", "d2", "--split", "test", "--limit", "3",
                 "--rollouts", "2", "--max-steps", "40", "--out", str(runs), *extra])


@pytest.mark.slow
def test_rollouts_on_ray_are_the_local_bytes(ray_cluster, board_set, tmp_path, capsys):
    assert _rollout(board_set, tmp_path / "local", "--workers", "2") == 0
    assert _rollout(board_set, tmp_path / "ray", "--executor", "ray") == 0
    printed = capsys.readouterr().out
    assert printed.count("done: 6 rollouts run, 0 already done") == 2 and "[6/6]" in printed
    local, on_ray = _outputs(tmp_path / "local"), _outputs(tmp_path / "ray")
    assert len(local) == 12 and sum(name.endswith(".kicad_pcb") for name in local) == 6
    assert on_ray.keys() == local.keys()
    assert [name for name in local if on_ray[name] != local[name]] == []
    assert _rollout(board_set, tmp_path / "ray", "--executor", "ray") == 0  # resumable
    assert "nothing to run (6 already done)" in capsys.readouterr().out


@pytest.mark.slow
def test_a_rollout_whose_ray_worker_dies_runs_again(ray_cluster, board_set, tmp_path, capsys):
    argv = ["rollout", str(board_set), "--config", "d2", "--limit", "1", "--max-steps", "40"]
    assert main([*argv, "--out", str(tmp_path / "local"), "--workers", "1"]) == 0
    assert main([*argv, "--out", str(tmp_path / "ray"), "--executor", "ray", "--agent",
                 "tests.env.agents_for_tests:KillsItsRayWorkerOnce"]) == 0
    assert "done: 1 rollouts run" in capsys.readouterr().out
    scratch = Path(os.environ["RAY_TEST_SCRATCH"])  # set by the ray_cluster fixture
    assert (scratch / "killed-board_00000-0").read_text() == "killed once"
    board = "board_00000/0.kicad_pcb"
    assert (tmp_path / "ray" / board).read_bytes() == (tmp_path / "local" / board).read_bytes()
    record = json.loads((tmp_path / "ray" / "board_00000" / "0.json").read_text())
    assert record["agent"] == "tests.env.agents_for_tests:KillsItsRayWorkerOnce"
    assert not list((tmp_path / "ray").rglob(".*"))  # no temporary file of the killed run

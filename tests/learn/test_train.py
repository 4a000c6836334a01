"""`pcbdata train` end to end on a tiny budget (a kill and the resume included), the shipped
checkpoint's rollouts (identical twice), and a short run beating the untrained network."""
from __future__ import annotations

import json
from dataclasses import replace

import pytest

pytest.importorskip("torch")

from pcbdata.agents.registry import make_agent  # noqa: E402
from pcbdata.cli import main  # noqa: E402
from pcbdata.core.errors import UserError  # noqa: E402
from pcbdata.core.hashing import sha256_file  # noqa: E402
from pcbdata.learn import train as training  # noqa: E402
from pcbdata.learn.agent import PolicyAgent  # noqa: E402
from pcbdata.learn.checkpoint import load_policy, shipped_path  # noqa: E402
from pcbdata.learn.policy import SetPolicy  # noqa: E402
from tests.learn.conftest import LEARN_BOARDS  # noqa: E402

TINY = training.Settings(dim=16, max_steps=8, bc_boards=2, bc_epochs=2, train_boards=4,
                         updates=1, envs=1, rollout_steps=6, minibatch=8, val_boards=1,
                         val_every=1, checkpoint_every=1)


class Killed(Exception):
    pass


def _kill_after(text: str):
    def log(line: str) -> None:
        if text in line:
            raise Killed(line)
    return log


def test_train_end_to_end_killed_then_resumed(tmp_path, capsys):
    out = tmp_path / "run"
    with pytest.raises(Killed):  # stops right after the cloning phase was saved
        training.train(out, replace(TINY, updates=2), log=_kill_after("bc: validation"))
    assert json.loads((out / "settings.json").read_text())["seed"] == 0
    argv = ["train", "--out", str(out)] + [
        f"--{k.replace('_', '-')}={v}" for k, v in vars(replace(TINY, updates=2)).items()
        if not isinstance(v, bool)]  # a flag (--no-finish) takes no value
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "bc: board" not in printed  # resumed: cloning is not done again
    assert "ppo: update 1/2" in printed and "ppo: update 2/2" in printed
    rows = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [(r["phase"], r["update"]) for r in rows] == [("bc", 0), ("ppo", 1), ("ppo", 2)]
    assert all(r["steps_per_s"] > 0 and "val_cp" in r for r in rows[1:])
    assert (out / "curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for name in ("best.pt", "checkpoints/update_00001.pt", "checkpoints/update_00002.pt"):
        policy, record = load_policy(out / name)
        assert record["settings"]["dim"] == 16 and isinstance(policy, SetPolicy)
    agent = make_agent(f"policy:{out / 'best.pt'}", 0)
    assert isinstance(agent, PolicyAgent) and agent.policy.dim == 16
    assert main([*argv, "--seed=1"]) == 2  # other settings in the same folder
    assert "other settings (seed)" in capsys.readouterr().err


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--teacher", "oracle", "one of scripted, scripted-shove"),
    ("--sampling-temperature", "0", "must be > 0")])
def test_bad_settings_are_refused_before_a_run_folder_exists(tmp_path, capsys, option, value,
                                                            message):
    out = tmp_path / "run"
    assert main(["train", "--out", str(out), option, value]) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_a_missing_checkpoint_is_a_user_error(tmp_path):
    with pytest.raises(UserError, match="no such checkpoint"):
        make_agent(f"policy:{tmp_path / 'none.pt'}", 0)


def test_a_checkpoint_of_another_format_is_refused_with_the_reason(tmp_path):
    import torch

    old = tmp_path / "old.pt"
    torch.save({"format": 1, "dim": 16, "state": SetPolicy(dim=16).state_dict()}, old)
    with pytest.raises(UserError, match="format 1, this pcbdata reads format 2"):
        load_policy(old)


def test_shipped_policy_routes_and_its_rollouts_are_identical(learn_set, tmp_path, capsys):
    assert shipped_path().is_file()
    runs = []
    for name in ("a", "b"):
        out = tmp_path / name
        argv = ["rollout", str(learn_set), "--config", "d2", "--agent", "policy",
                "--max-steps", "60", "--drc", "terminal", "--workers", "1", "--out", str(out)]
        assert main(argv) == 0
        runs.append(out)
    assert "done: 8 rollouts run" in capsys.readouterr().out
    routed = 0
    for board in sorted(p.name for p in runs[0].iterdir()):
        a, b = (json.loads((r / board / "0.json").read_text()) for r in runs)
        for record in (a, b):  # the wall time and the machine's load differ run to run
            record.pop("time_s"), record.pop("machine")
        assert a == b and a["agent"] == "policy" and a["engine_failure"] is None
        assert a["agent_identity"]["checkpoint_sha256"] == sha256_file(shipped_path())
        assert a["agent_identity"]["sampling"]["temperature"] > 0
        assert ((runs[0] / board / "0.kicad_pcb").read_bytes()
                == (runs[1] / board / "0.kicad_pcb").read_bytes())
        routed += a["unconnected"] == 0
    assert routed >= 7, f"the shipped policy completed {routed} of {LEARN_BOARDS} D2 boards"


def test_short_run_beats_the_untrained_network():
    """Cloning on a few boards raises the greedy validation return (seconds, not minutes)."""
    import torch

    s = replace(TINY, dim=32, max_steps=30, bc_boards=6, bc_epochs=15, val_boards=3,
                minibatch=32)
    torch.manual_seed(s.seed)
    policy = SetPolicy(dim=s.dim)
    dev = torch.device("cpu")
    before = training.validate(policy, s, dev)
    training.clone(policy, training.scripted_demos(s, lambda _: None), s, dev, lambda _: None)
    after = training.validate(policy, s, dev)
    assert after["val_return"] > before["val_return"], (before, after)

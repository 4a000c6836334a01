"""`pcbdata train`'s variants (GRPO, the terminal reward, no finish, reward weights): each
trains end to end on a tiny budget and its checkpoint rolls out; without finish the action is
masked everywhere; GRPO's advantages are z-scores within a group."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("torch")

from pcbdata.agents.scripted import ShovingScriptedAgent  # noqa: E402
from pcbdata.cli import main  # noqa: E402
from pcbdata.core.errors import UserError  # noqa: E402
from pcbdata.env.types import FINISH, ROUTING  # noqa: E402
from pcbdata.env.wrappers.rl import make_rl_env  # noqa: E402
from pcbdata.learn import train as training  # noqa: E402
from pcbdata.learn.agent import PolicyAgent  # noqa: E402
from pcbdata.learn.checkpoint import load_policy, save_policy  # noqa: E402
from pcbdata.learn.grpo import group_advantages  # noqa: E402
from pcbdata.learn.policy import SetPolicy  # noqa: E402
from pcbdata.learn.teacher import WithoutFinish  # noqa: E402

TINY = training.Settings(dim=16, max_steps=8, bc_boards=2, bc_epochs=2, train_boards=4,
                         updates=1, envs=1, rollout_steps=6, minibatch=8, val_boards=1,
                         val_every=1, checkpoint_every=1)


def test_group_advantages_are_z_scores_within_the_group():
    adv = group_advantages(np.asarray([1.0, 2.0, 3.0, 6.0]))
    assert adv.mean() == pytest.approx(0.0, abs=1e-12)
    assert adv.std() == pytest.approx(1.0, rel=1e-6)
    assert list(np.argsort(adv)) == [0, 1, 2, 3]
    assert adv[3] == pytest.approx((6.0 - 3.0) / np.std([1.0, 2.0, 3.0, 6.0]), rel=1e-6)
    assert np.all(group_advantages(np.full(16, 4.2)) == 0.0)  # equal returns teach nothing
    shifted = group_advantages(np.asarray([101.0, 102.0, 103.0, 106.0]))
    assert shifted == pytest.approx(adv)  # only the differences within the group count


@pytest.mark.parametrize("argv", [
    ["--algo", "grpo", "--group", "3", "--envs", "2"],
    ["--reward", "terminal"],
    ["--no-finish"],
    ["--lw", "0", "--lv", "0.05"],
], ids=["grpo", "terminal", "no-finish", "weights"])
def test_variant_trains_end_to_end_and_its_checkpoint_rolls_out(learn_set, tmp_path, capsys,
                                                                argv):
    out = tmp_path / "run"
    tiny = [f"--{k.replace('_', '-')}={v}" for k, v in vars(replace(TINY, updates=2)).items()
            if k not in training.variant(TINY) and k != "init"]
    assert main(["train", "--out", str(out), *tiny, *argv]) == 0
    printed = capsys.readouterr().out
    algo = "grpo" if "grpo" in argv else "ppo"
    assert f"{algo}: update 2/2" in printed and f"2 {algo.upper()} updates" in printed
    rows = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [(r["phase"], r["update"]) for r in rows] == [("bc", 0), (algo, 1), (algo, 2)]
    assert all({"val_wl", "val_vias"} <= set(r) for r in rows)
    assert (out / "curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    _, record = load_policy(out / "best.pt")
    expected = {"algo": algo, "reward": "terminal" if "terminal" in argv else "dense",
                "no_finish": "--no-finish" in argv,
                "lw": 0.0 if "--lw" in argv else 0.002, "lv": 0.05 if "--lv" in argv else 0.1}
    assert {k: record["variant"][k] for k in expected} == expected
    runs = tmp_path / "rollouts"
    assert main(["rollout", str(learn_set), "--config", "d2", "--agent",
                 f"policy:{out / 'best.pt'}", "--limit", "2", "--rollouts", "2",
                 "--max-steps", "12", "--drc", "terminal", "--workers", "1",
                 "--out", str(runs)]) == 0
    records = [json.loads(p.read_text()) for p in sorted(runs.glob("*/[0-9].json"))]
    assert len(records) == 4 and all(r["engine_failure"] is None for r in records)


def test_without_finish_the_action_is_masked_everywhere():
    """Environment option finish=False: the type mask, the RL wrapper's joint masks and the
    cloning teacher never offer or send finish, and a finish sent anyway changes nothing."""
    env = make_rl_env("d2", split="train", count=2, max_steps=60, drc="terminal", finish=False)
    raw_env = env.unwrapped
    try:
        obs, info = env.reset(seed=0, options={"index": 0})
        raw, raw_info = raw_env._observation(), env.raw_info
        teacher, done, sent, routing = WithoutFinish(ShovingScriptedAgent(seed=0)), False, [], 0
        while not done:
            assert raw_info["action_mask"]["type"][FINISH] == 0
            assert not obs["index_mask"][FINISH].any() and not obs["mode_mask"][FINISH].any()
            act = teacher.act(raw, raw_info)
            if teacher.done:
                break
            sent.append(int(act["type"]))
            routing += int(raw["router_head"]["phase"]) == ROUTING
            obs, _, term, trunc, _ = env.step(act)
            raw, raw_info, done = raw_env._observation(), env.raw_info, term or trunc
        assert FINISH not in sent and routing > 0
        assert raw_info["unconnected"] == 0  # the teacher routes the board by make_line
        env.reset(seed=0, options={"index": 1})
        scripted = ShovingScriptedAgent(seed=0)
        while int(raw_env._observation()["router_head"]["phase"]) != ROUTING:
            env.step(scripted.act(raw_env._observation(), env.raw_info))
        before = raw_env._observation()["routing_geometry"]["track_count"]
        env.step({"type": FINISH, "net": 0, "candidate": 0, "mode": 0})
        assert env.raw_info["rejected"] == "finish is not offered (option finish=False)"
        assert raw_env._observation()["routing_geometry"]["track_count"] == before
    finally:
        env.close()


def _sent_types(agent: PolicyAgent, steps: int) -> list[int]:
    env = make_rl_env("d2", split="train", count=1, max_steps=steps, drc="terminal")
    try:
        env.reset(seed=0, options={"index": 0})
        raw, info, done, sent = env.unwrapped._observation(), env.raw_info, False, []
        while not done:
            act = agent.act(raw, info)
            sent.append(int(act["type"]))
            _, _, term, trunc, info = env.unwrapped.step(act)
            raw, done = env.unwrapped._observation(), term or trunc
        return sent
    finally:
        env.close()


def test_a_no_finish_checkpoint_never_sends_finish(tmp_path):
    """In a rollout's environment (finish offered), the agent of a checkpoint trained without
    finish masks it out; the same weights without that record do send it."""
    import torch

    torch.manual_seed(3)
    policy = SetPolicy(dim=16)
    with torch.no_grad():  # a network that takes finish whenever it is offered
        policy.type_head.bias[FINISH] = 50.0
    for name, no_finish in (("with.pt", False), ("without.pt", True)):
        save_policy(policy, tmp_path / name,
                    {"variant": {"no_finish": no_finish}, "sampling_temperature": 1.0})
    with_finish = _sent_types(PolicyAgent(seed=1, path=str(tmp_path / "with.pt")), 40)
    without = _sent_types(PolicyAgent(seed=1, path=str(tmp_path / "without.pt")), 40)
    assert FINISH in with_finish
    assert FINISH not in without and len(without) == 40


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--algo", "a2c", "invalid choice"), ("--reward", "step", "invalid choice"),
    ("--lw", "-1", "reward weights must be >= 0"), ("--group", "1", "at least 2 episodes")])
def test_bad_variant_settings_are_refused(tmp_path, capsys, option, value, message):
    out = tmp_path / "run"
    try:
        code = main(["train", "--out", str(out), option, value])
    except SystemExit as exc:  # argparse's own refusal of a choice
        code = exc.code
    assert code == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_init_starts_from_a_checkpoint_without_cloning(tmp_path):
    start = tmp_path / "start.pt"
    save_policy(SetPolicy(dim=16), start, {})
    logged: list[str] = []
    training.train(tmp_path / "run", replace(TINY, init=str(start)), log=logged.append)
    assert not any(line.startswith("bc:") and "board" in line for line in logged)
    assert any(line.startswith("init:") for line in logged)
    with pytest.raises(UserError, match="width 16, the run's --dim is 32"):
        training.train(tmp_path / "other", replace(TINY, dim=32, init=str(start)))


def test_value_warmup_trains_only_the_value_head(tmp_path):
    """--value-warmup N: PPO's first N updates leave every parameter but the critic's."""
    import torch

    start = tmp_path / "start.pt"
    torch.manual_seed(0)
    save_policy(SetPolicy(dim=16), start, {})
    before, _ = load_policy(start)
    s = replace(TINY, init=str(start), value_warmup=1, rollout_steps=8)
    training.train(tmp_path / "run", s, log=lambda _: None)
    after, _ = load_policy(tmp_path / "run" / "checkpoints" / "update_00001.pt")
    old, new = before.state_dict(), after.state_dict()
    moved = {k for k in old if not torch.equal(old[k], new[k])}
    assert moved and all(k.startswith("value_head.") for k in moved), moved

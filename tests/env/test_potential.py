"""The episode's summed reward is Phi(s_T) - Phi(s_0); under the evaluator's count it equals
the Pot. that `pcbdata.evaluator.score` gives the saved board (SPEC section 6)."""
from __future__ import annotations

import math

import pytest

from pcbdata.agents.random import RandomAgent
from pcbdata.agents.scripted import ScriptedAgent
from pcbdata.env.reward import EVALUATOR_COUNTING, Telescope
from pcbdata.env.types import MARK_OBSTACLES, NET_SELECT, WALKAROUND
from pcbdata.runners.rollout import run_episode
from tests.env.agents_for_tests import StopsEarly
from tests.helpers import skip_without_snapshot


def test_telescope_sums_to_the_potential_gain():
    phis = [-3.0, -2.5, -2.5, 1e-17, 7.123456789, 7.0]
    tele = Telescope(phis[0], per_step=True)
    total = sum(tele.reward(p, final=i == len(phis) - 1) for i, p in enumerate(phis[1:], 1))
    assert total == pytest.approx(phis[-1] - phis[0], abs=1e-12)
    terminal = Telescope(phis[0], per_step=False)
    rewards = [terminal.reward(p, final=i == len(phis) - 1) for i, p in enumerate(phis[1:], 1)]
    assert rewards[:-1] == [0.0] * (len(rewards) - 1)


def _episodes(board_set, make_env, walkaround: bool):
    """(instance folder, saved board, summed reward, env info) for scripted and random episodes
    on every board of the tiny set, with DRC every step and at the end only."""
    out = []
    for config, boards in (("d2", 4), ("d1-g10", 2)):
        for drc in ("step", "terminal"):
            env = make_env(config, counting=EVALUATOR_COUNTING, drc=drc, max_steps=40)
            # DRC after every step is the slow part: half the boards with it, all without
            for index in range(boards // 2 if drc == "step" else boards):
                board_id = f"board_{index:05d}"
                agents = [ScriptedAgent(seed=index, mode=MARK_OBSTACLES), RandomAgent(seed=index)]
                if walkaround:
                    agents.append(ScriptedAgent(seed=index, mode=WALKAROUND))
                for n, agent in enumerate(agents):
                    record = _until_end(env, agent, board_id, index)
                    saved = board_set / "saved" / f"{config}-{drc}-{board_id}-{n}.kicad_pcb"
                    env.unwrapped.save(saved)
                    out.append((board_set / config / "test" / board_id, saved, record))
    return out


def _until_end(env, agent, board_id: str, seed: int) -> dict:
    """An episode to its end: `run_episode` ends an agent that is done with
    `finish_episode()`, so drc="terminal" has run its final DRC."""
    record = run_episode(env, agent, board_id, seed)
    assert record["terminated"] or record["truncated"]
    return record


def test_summed_reward_equals_the_evaluators_pot(board_set, make_env, kicad_pool):
    from pcbdata.evaluator import Evaluator

    episodes = _episodes(board_set, make_env, walkaround=True)
    with Evaluator(pool=kicad_pool) as evaluator:
        scored = dict(evaluator.score_many([(inst, saved) for inst, saved, _ in episodes]))
    assert len(scored) == len(episodes) >= 18
    connected = 0
    for index, (_, saved, record) in enumerate(episodes):
        result = scored[index]
        assert result["status"] == "ok", (saved, result["reason"])
        assert math.isclose(result["pot"], record["reward"], rel_tol=0, abs_tol=1e-9), \
            (saved, result["pot"], record["reward"])
        connected += result["unconnected"] == 0
    assert connected >= 4  # the mark-obstacles scripted agent joins every net of small boards


def test_connectivity_count_matches_drc(make_env):
    """U from KiCad's connectivity (steps without DRC) equals the DRC's unconnected items."""
    env = make_env(max_steps=60)
    agent = ScriptedAgent(seed=1, mode=MARK_OBSTACLES)
    obs, info = env.reset(seed=1)
    for _ in range(60):
        assert int(obs["routing_geometry"]["unconnected"]) == info["unconnected"]
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        if terminated or truncated or agent.done:
            break


def test_terminal_reward_pays_once_the_same_total(make_env):
    totals = {}
    for reward in ("dense", "terminal"):
        env = make_env(reward=reward, max_steps=12, counting="evaluation", drc="terminal",
                       weights={"lw": 0.01, "lv": 0.5, "net_weight": 3.0})
        agent = ScriptedAgent(seed=0, mode=MARK_OBSTACLES)
        obs, info = env.reset(seed=0, options={"index": 1})
        rewards = []
        for _ in range(12):
            obs, r, terminated, truncated, info = env.step(agent.act(obs, info))
            rewards.append(r)
            if terminated or truncated:
                break
        if reward == "terminal":
            assert all(r == 0.0 for r in rewards[:-1]) and rewards[-1] != 0.0
        totals[reward] = sum(rewards)
    assert totals["dense"] == pytest.approx(totals["terminal"], abs=1e-9)


def test_the_dense_rewards_earlier_name_is_still_read():
    from pcbdata.env.errors import EnvValueError
    from pcbdata.env.options import make_options

    assert make_options().reward == "dense"
    assert make_options(reward="step").reward == "dense"
    with pytest.raises(EnvValueError, match="not one of dense, terminal"):
        make_options(reward="per-step")


def test_d3_summed_reward_equals_pot(d3_set, kicad_pool, tmp_path):
    """Real boards (netclasses, zones, several layers), several instances per KiCad worker."""
    import gymnasium as gym

    from pcbdata.evaluator import Evaluator

    if not any((d3_set / "d3-a" / "test").glob("*/board.kicad_pcb")):
        skip_without_snapshot("needs a built D3 set with d3-a test boards: PCBDATA_D3_SET=<set>")
    env = gym.make("pcbdata/Route-d3-a-v2", root=str(d3_set), drc="terminal", max_steps=60,
                   counting=EVALUATOR_COUNTING)
    try:
        pairs, rewards = [], []
        for board_id in env.unwrapped.source.board_ids[:6]:
            record = _until_end(env, ScriptedAgent(mode=MARK_OBSTACLES), board_id, 0)
            saved = tmp_path / f"{board_id}.kicad_pcb"
            env.unwrapped.save(saved)
            pairs.append((d3_set / "d3-a" / "test" / board_id, saved))
            rewards.append(record["reward"])
    finally:
        env.close()
    with Evaluator(pool=kicad_pool) as evaluator:
        for index, result in evaluator.score_many(pairs):
            assert result["status"] == "ok", result["reason"]
            assert math.isclose(result["pot"], rewards[index], abs_tol=1e-9), pairs[index]


def _stopping_agents(seed: int) -> list:
    """Agents that end their episode early: scripted (finish in walkaround mode) and random
    (dangling tracks and vias, shorts: what only the final DRC sees with drc="terminal")."""
    return [StopsEarly(ScriptedAgent(seed=seed), 9), StopsEarly(RandomAgent(seed=seed), 25)]


def _early_episodes(env, board_ids, folder, saved_dir) -> list[tuple]:
    """(instance, saved board, record) of every stopping agent on every board."""
    out = []
    for index, board_id in enumerate(board_ids):
        for n, agent in enumerate(_stopping_agents(index)):
            record = run_episode(env, agent, board_id, index)
            assert record["truncated"] and not record["terminated"], record
            drc = env.unwrapped.options.drc
            saved = saved_dir / f"{drc}-{board_id}-{n}.kicad_pcb"
            env.unwrapped.save(saved)
            out.append((folder / board_id, saved, record))
    return out


def _assert_pot(kicad_pool, episodes) -> None:
    """Each summed reward equals the Pot. of its saved board (the evaluator's Phi(final) -
    Phi(bare) under the strict count, the environment's default), and some boards carry
    violations, so the final DRC's correction is exercised."""
    from pcbdata.evaluator import Evaluator

    with Evaluator(pool=kicad_pool) as evaluator:
        scored = dict(evaluator.score_many([(inst, saved) for inst, saved, _ in episodes]))
    assert len(scored) == len(episodes)
    for index, (_, saved, record) in enumerate(episodes):
        result = scored[index]
        assert result["status"] == "ok", (saved, result["reason"])
        assert math.isclose(result["pot"], record["reward"], rel_tol=0, abs_tol=1e-9), \
            (saved, result["pot"], record["reward"])
    assert sum(scored[i]["drv_strict"] > 0 for i in scored) >= 2


def test_an_early_end_pays_the_final_drc_d2(board_set, make_env, kicad_pool, tmp_path):
    """Default options (strict counting), DRC every step and at the end: the rewards of an
    episode its agent ends early sum to the Pot. of the saved board, and both DRC options
    give the same sum."""
    episodes = []
    for drc in ("step", "terminal"):
        env = make_env("d2", drc=drc)
        episodes += _early_episodes(env, [f"board_{i:05d}" for i in range(4)],
                                    board_set / "d2" / "test", tmp_path)
    _assert_pot(kicad_pool, episodes)
    half = len(episodes) // 2
    for (_, _, step), (_, _, terminal) in zip(episodes[:half], episodes[half:], strict=True):
        assert step["reward"] == pytest.approx(terminal["reward"], abs=1e-9)


def test_an_early_end_pays_the_final_drc_d3(d3_set, kicad_pool, tmp_path):
    """The same on real boards (D3-A, the two smallest test boards): the via_dangling /
    track_dangling an early end leaves is in the last reward."""
    import gymnasium as gym

    if not any((d3_set / "d3-a" / "test").glob("*/board.kicad_pcb")):
        skip_without_snapshot("needs a built D3 set with d3-a test boards: PCBDATA_D3_SET=<set>")
    episodes = []
    for drc in ("step", "terminal"):
        env = gym.make("pcbdata/Route-d3-a-v2", root=str(d3_set), drc=drc)
        try:
            board_ids = env.unwrapped.source.board_ids[:2]
            episodes += _early_episodes(env, board_ids, d3_set / "d3-a" / "test", tmp_path)
        finally:
            env.close()
    _assert_pot(kicad_pool, episodes)


def test_finish_episode_ends_once_and_pays_what_is_owed(make_env):
    """reward="terminal" pays nothing until the end: finish_episode pays Phi(s_T) - Phi(s_0)
    whole, truncates, counts no step; afterwards it and step() change nothing."""
    env = make_env("d2", reward="terminal", drc="terminal")
    u = env.unwrapped
    obs, info = env.reset(seed=0, options={"index": 0})
    phi0, agent = info["phi"], ScriptedAgent(seed=0)
    for _ in range(8):
        obs, reward, terminated, truncated, info = env.step(agent.act(obs, info))
        assert reward == 0.0 and not (terminated or truncated)
    obs, reward, terminated, truncated, info = u.finish_episode()
    assert (terminated, truncated, info["step"], info["finished_early"]) == (False, True, 8, True)
    assert info["drc_fresh"] and reward == pytest.approx(info["phi"] - phi0, abs=1e-12)
    assert reward != 0.0
    again = u.finish_episode()
    assert again[1:4] == (0.0, False, True) and "ended" in again[4]["rejected"]
    stepped = env.step({"type": NET_SELECT, "net": 0, "candidate": 0, "mode": 0})
    assert stepped[1] == 0.0 and "ended" in stepped[4]["rejected"]

"""Steps on real boards: the phase machine, malformed and masked actions as no-ops with a
reason, determinism, episode end, engine failures."""
from __future__ import annotations

import math
import os
import signal

import numpy as np
import pytest

from pcbdata.agents.random import RandomAgent
from pcbdata.agents.scripted import action
from pcbdata.env.types import (
    FINISH,
    IDLE,
    MAKE_LINE,
    MARK_OBSTACLES,
    NET_END,
    NET_SELECT,
    PUSH_N_SHOVE,
    START_ROUTE,
    WALKAROUND,
)


def _start(env, net: int = 0):
    """Reset to board 0, select `net` and start at the first pad from which `finish` is
    allowed (a pad on a layer where another pad of the net is)."""
    env.reset(seed=0, options={"index": 0})
    _, _, _, _, info = env.step(action(NET_SELECT, net=net))
    for candidate in np.flatnonzero(info["action_mask"]["candidate"]):
        result = env.step(action(START_ROUTE, candidate=int(candidate)))
        if result[4]["action_mask"]["type"][FINISH]:
            return result
        env.step(action(NET_END))
        env.step(action(NET_SELECT, net=net))
    raise AssertionError("no start pad allows finish")


def test_phase_machine_masks(make_env):
    env = make_env()
    obs, info = env.reset(seed=0)
    assert info["phase"] == "no_net"
    assert list(info["action_mask"]["type"]) == [1, 1, 0, 0, 0, 0, 0]
    assert info["action_mask"]["mode"].tolist() == [1, 1, 1]
    assert info["masked_modes"] == {}
    obs, _, _, _, info = env.step(action(NET_SELECT, net=0))
    assert info["phase"] == "net" and list(info["action_mask"]["type"]) == [1, 1, 1, 1, 0, 0, 0]
    obs, _, _, _, info = _start(env)
    assert info["phase"] == "routing"
    assert info["action_mask"]["type"][[IDLE, MAKE_LINE, NET_END, FINISH]].all()
    assert not info["action_mask"]["type"][[NET_SELECT, START_ROUTE]].any()


BAD_ACTIONS = [
    ("not a dict", "malformed"),
    ({"type": float("nan")}, "not an integer"),
    ({"type": 99}, "out of range"),
    ({"type": [1, 2]}, "expected one integer"),
    ({"type": 1, "net": 31}, "unknown net"),
    ({"type": 1, "net": -1}, "out of range"),
    ({"type": 4, "candidate": 0}, "masked in phase no_net"),
    ({"type": 1, "bogus": 0}, "unknown keys"),
]


@pytest.mark.parametrize("bad, reason", BAD_ACTIONS)
def test_bad_action_is_a_no_op_with_reason(make_env, bad, reason):
    env = make_env()
    obs0, _ = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.unwrapped.step(bad)
    assert reason in info["rejected"]
    assert reward == 0.0 and not terminated and not truncated
    assert info["phase"] == "no_net" and obs["step"] == 1
    np.testing.assert_array_equal(obs["routing_geometry"]["tracks"],
                                  obs0["routing_geometry"]["tracks"])


def test_push_n_shove_without_blockers_routes_like_walkaround(make_env):
    runs = []
    for mode in (WALKAROUND, PUSH_N_SHOVE):
        env = make_env()
        env.reset(seed=0, options={"index": 0})
        _start(env)
        obs, reward, _, _, info = env.step(action(FINISH, mode=mode))
        runs.append((obs["routing_geometry"]["tracks"], reward, info["router"]["ok"]))
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    assert runs[0][1:] == runs[1][1:] == (runs[0][1], True)


def test_mark_obstacles_finish_connects_and_rewards(make_env):
    env = make_env()
    _, info0 = env.reset(seed=0, options={"index": 0})
    _start(env)
    obs, reward, _, _, info = env.step(action(FINISH, mode=MARK_OBSTACLES))
    assert info["router"]["ok"] and info["rejected"] is None
    assert info["unconnected"] == info0["unconnected"] - 1
    assert obs["routing_geometry"]["track_count"] >= 1 and reward > 0


def test_step_after_end_and_step_limit(make_env):
    env = make_env(max_steps=3)
    env.reset(seed=1)
    for _ in range(3):
        _, _, terminated, truncated, info = env.step(action(IDLE))
    assert truncated and not terminated
    _, reward, _, truncated, info = env.step(action(IDLE))
    assert "episode has ended" in info["rejected"] and reward == 0.0 and truncated


def _run(env, seed: int, steps: int):
    agent = RandomAgent(seed)
    obs, info = env.reset(seed=seed)
    trace = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(agent.act(obs, info))
        trace.append((obs, reward, terminated, truncated, info["rejected"], info["phi"]))
        if terminated or truncated:
            break
    return trace


def _equal(a, b) -> bool:
    from gymnasium.utils.env_checker import data_equivalence

    return data_equivalence(a, b)


def test_same_seed_same_actions_same_everything(make_env):
    env_a, env_b = make_env(), make_env()
    assert _equal(_run(env_a, 3, 40), _run(env_b, 3, 40))


def test_random_actions_never_crash(make_env):
    """Seeded masked-random and unmasked-random actions, a few hundred steps, D2 and D1."""
    for config in ("d2", "d1-g10"):
        env = make_env(config, max_steps=120, drc="terminal")
        space = env.action_space
        space.seed(5)
        agent = RandomAgent(5)
        obs, info = env.reset(seed=5)
        for step in range(240):
            act = space.sample() if step % 3 == 0 else agent.act(obs, info)
            obs, reward, terminated, truncated, info = env.step(act)
            assert math.isfinite(reward) and env.observation_space.contains(obs)
            if terminated or truncated:
                obs, info = env.reset(seed=step)


def test_d1_masks_vias_and_back_layer(make_env):
    env = make_env("d1-g10")
    obs, _, _, _, info = _start(env)
    assert not info["action_mask"]["candidate_via"].any()
    assert not info["action_mask"]["type"][5]
    cands = obs["router_head"]["candidates"]
    assert all(c[3] == 0 for c in cands if c[0] != 0)
    ring = cands[:8]
    pitch = 10.0
    used = [c for c in ring if c[0] != 0]
    assert len(used) == 4
    assert all(abs((c[1] - 0.75 * pitch) / pitch - round((c[1] - 0.75 * pitch) / pitch)) < 1e-9
               for c in used)


def test_engine_crash_truncates_and_next_reset_recovers(make_env):
    env = make_env()
    env.reset(seed=0)
    session = env.unwrapped._session
    pid = session._pool.call("os:getpid")
    os.kill(pid, signal.SIGKILL)
    _start_after_kill = env.step(action(NET_SELECT, net=0))  # no KiCad call: still fine
    obs, info = _start_after_kill[0], _start_after_kill[4]
    first = int(np.flatnonzero(info["action_mask"]["candidate"])[0])
    env.step(action(START_ROUTE, candidate=first))
    _, reward, terminated, truncated, info = env.step(action(FINISH, mode=MARK_OBSTACLES))
    assert truncated and not terminated and reward == 0.0
    assert "worker" in info["engine_failure"]
    obs, info = env.reset(seed=0)
    assert info["unconnected"] > 0
    _, _, _, _, info = env.step(action(NET_SELECT, net=0))
    assert info["rejected"] is None


def test_unknown_board_id_is_a_clear_error(make_env):
    env = make_env()
    with pytest.raises(ValueError, match="not in this environment"):
        env.reset(options={"board_id": "board_99999"})


def test_dataset_rows_are_a_source(make_env, board_set):
    """Rows as `load_dataset` gives them (board text columns) are written back and routed."""
    rows = []
    for index in range(2):
        folder = board_set / "d2" / "test" / f"board_{index:05d}"
        rows.append({"config": "d2", "split": "test", "board_id": folder.name,
                     "board": (folder / "board.kicad_pcb").read_text(),
                     "project": (folder / "board.kicad_pro").read_text()})
    from_rows = make_env(root=None, rows=rows)
    from_set = make_env()
    obs_rows, info_rows = from_rows.reset(seed=0, options={"board_id": "board_00001"})
    obs_set, info_set = from_set.reset(seed=0, options={"board_id": "board_00001"})
    assert _equal(obs_rows, obs_set) and info_rows["net_names"] == info_set["net_names"]


def test_each_instance_keeps_its_own_rules(tmp_path, board_set):
    """One worker loads many instances: each must be judged by its own project (KiCad keeps a
    loaded project by path, so a reused staging path would leak the previous rules)."""
    import shutil

    import gymnasium as gym

    source = board_set / "d2" / "test" / "board_00000"
    for board_id, clearance in (("board_00000", "0.3"), ("board_00001", "0.5")):
        folder = tmp_path / "d2" / "test" / board_id
        shutil.copytree(source, folder)
        project = folder / "board.kicad_pro"
        text = project.read_text().replace('"clearance": 0.3', f'"clearance": {clearance}')
        project.write_text(text)
    env = gym.make("pcbdata/Route-d2-v2", root=str(tmp_path))
    try:
        seen = []
        for board_id in ("board_00000", "board_00001", "board_00000"):
            obs, info = env.reset(options={"board_id": board_id})
            seen.append(round(float(obs["board_static"]["rules"][0]), 6))
        assert seen == [0.3, 0.5, 0.3]
    finally:
        env.close()


def test_a_board_that_does_not_load_is_a_clear_error(tmp_path, board_set):
    import shutil

    import gymnasium as gym

    from pcbdata.env.env import BoardLoadError

    good = tmp_path / "d2" / "test" / "board_00000"
    shutil.copytree(board_set / "d2" / "test" / "board_00000", good)
    bad = tmp_path / "d2" / "test" / "board_00001"
    shutil.copytree(good, bad)
    (bad / "board.kicad_pcb").write_text("(kicad_pcb (version 20240108) (garbage")
    env = gym.make("pcbdata/Route-d2-v2", root=str(tmp_path))
    try:
        with pytest.raises(BoardLoadError, match="board_00001"):
            env.reset(options={"board_id": "board_00001"})
        obs, info = env.reset(options={"board_id": "board_00000"})  # the env goes on
        assert info["unconnected"] > 0
    finally:
        env.close()


def test_copper_text_is_an_obstacle(tmp_path, board_set):
    """Copper drawings and texts (no net) are obstacles for the walkaround router: KiCad's DRC
    checks tracks against them (a real D3-A board has board texts on F.Cu)."""
    import shutil

    import gymnasium as gym

    folder = tmp_path / "d2" / "test" / "board_00000"
    shutil.copytree(board_set / "d2" / "test" / "board_00000", folder)
    board = folder / "board.kicad_pcb"
    text = board.read_text()
    label = ('(gr_text "COPPER" (at 5 5 0) (layer "F.Cu") '
             '(uuid "91028994-e5d7-40f6-82ad-82470d61bbc7") '
             '(effects (font (size 1.5 1.5) (thickness 0.3))))\n')
    board.write_text(text[: text.rstrip().rfind(")")] + label + ")\n")
    env = gym.make("pcbdata/Route-d2-v2", root=str(tmp_path))
    try:
        env.reset(options={"board_id": "board_00000"})
        graphics = env.unwrapped.static.graphics
        assert [g["layer"] for g in graphics] == ["F.Cu"]
        router = env.unwrapped._get_router()
        net = env.unwrapped.static.nets[0]
        across = ((2_000_000, 5_000_000), (8_000_000, 5_000_000))
        assert not router.segment_is_clear(net.name, "F.Cu", *across, net.track_width,
                                           net.clearance)
        assert router.segment_is_clear(net.name, "B.Cu", *across, net.track_width, net.clearance)
    finally:
        env.close()


def test_worker_runs_with_the_drc_wait_preload_unless_turned_off(make_env):
    from pcbdata.kicad import fastwait

    if fastwait.library_path() is None:
        pytest.skip("the fastwait preload is not built (scripts/build-fastwait.sh)")
    for fast_drc, loaded in ((True, True), (False, False)):
        env = make_env(fast_drc=fast_drc)
        env.reset(seed=0)
        pool = env.unwrapped._session._pool
        assert (pool.call("pcbdata.kicad.fastwait:shortened_sleeps") is not None) == loaded


def test_close_leaves_no_worker_behind(make_env):
    import time

    env = make_env()
    env.reset(seed=0)
    pid = env.unwrapped._session._pool.call("os:getpid")
    os.kill(pid, 0)  # alive
    env.close()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    raise AssertionError(f"KiCad worker {pid} still runs after close()")

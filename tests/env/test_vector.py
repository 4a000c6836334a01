"""Vectorised use of the RL wrapper: `make_vector_env` (Gymnasium's AsyncVectorEnv over spawned
workers, one KiCad engine each) resets, steps masked random actions through the observation's
masks and `call("action_masks")`, resets finished episodes itself, and leaves no process behind
when closed."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pcbdata.env.wrappers.rl import make_vector_env, sample_action
from tests.processes import marked_processes, new_marker, wait_for

N = 2


def _one(obs: dict, i: int) -> dict:
    return {key: value[i] for key, value in obs.items()}


def test_two_spawned_environments(board_set, monkeypatch):
    marker = new_marker()
    monkeypatch.setenv("PCBDATA_TEST_MARKER", marker)  # inherited by every process started
    envs = make_vector_env("d2", N, root=str(board_set), max_steps=10)
    seen: dict[int, str] = {}
    try:
        obs, info = envs.reset(seed=[0, 1])
        assert obs["entities"].shape[0] == N and list(info["board_id"]) != ["", ""]
        rng = np.random.default_rng(0)
        ended = np.zeros(N, dtype=bool)
        episodes = 0
        for _ in range(24):
            masks = envs.call("action_masks")
            for i in range(N):
                np.testing.assert_array_equal(masks[i], obs["action_mask"][i].astype(bool))
            actions = np.stack([sample_action(_one(obs, i), rng) for i in range(N)])
            obs, reward, terminated, truncated, info = envs.step(actions)
            assert reward.shape == (N,) and obs["entity_mask"].shape[0] == N
            # A step right after an episode's end is Gymnasium's reset of that environment.
            assert all(r == "" for r, e in zip(info["rejected"], ended, strict=True) if not e)
            ended = terminated | truncated
            episodes += int(ended.sum())
            seen.update(marked_processes(marker))
        assert episodes >= N  # max_steps=10 in 24 steps: every environment ended one
        assert sum("pcbdata.kicad.worker" in c for c in seen.values()) >= N
    finally:
        envs.close()
    assert wait_for(lambda: not _left(marker), 10), _left(marker)


def _left(marker: str) -> dict[int, str]:
    """Marked processes still alive, but this process's own multiprocessing resource tracker:
    any spawn start launches it, and it ends with its parent (Python's behaviour)."""
    return {pid: cmd for pid, cmd in marked_processes(marker).items()
            if not ("multiprocessing.resource_tracker" in cmd and _parent(pid) == os.getpid())}


def _parent(pid: int) -> int:
    stat = Path(f"/proc/{pid}/stat").read_text()
    return int(stat.rsplit(")", 1)[1].split()[1])

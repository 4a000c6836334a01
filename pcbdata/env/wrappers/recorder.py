"""Rollouts written from inside an environment, for `pcbdata eval`: `RunRecorder` makes resets
without options walk a schedule of (board, rollout) and writes each finished episode as
`RUNS/<board_id>/<rollout>.kicad_pcb` + `<rollout>.json` (the fields `pcbdata rollout` writes).

Meant for vectorised environments, where the caller cannot save one sub-environment's board at
the moment its episode ends (Gymnasium resets it on the next step): each process saves its own
episodes. Give each environment its own boards (`make_vector_env` splits them), so no two write
the same file. After the schedule, episodes go on on boards drawn by the environment and are not
written (`info["scheduled_left"]` counts the scheduled episodes not yet finished).
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import gymnasium as gym

from pcbdata.core.fsutil import write_atomic


class RunRecorder(gym.Wrapper):
    def __init__(self, env: gym.Env, runs_dir, boards=None, rollouts: int = 1,
                 agent: str = "random"):
        super().__init__(env)
        ids = list(boards) if boards is not None else \
            list(env.unwrapped.source.board_ids)  # type: ignore[attr-defined]
        self.schedule = [(b, r) for r in range(rollouts) for b in ids]
        self.runs_dir, self.agent = Path(runs_dir), agent
        self._current: tuple[str, int] | None = None
        self._episode = {"reward": 0.0, "steps": 0, "began": 0.0}

    def reset(self, *, seed=None, options=None):
        self._current = None
        if not options and self.schedule:
            self._current = self.schedule.pop(0)
            options = {"board_id": self._current[0]}
        self._episode = {"reward": 0.0, "steps": 0, "began": time.perf_counter()}
        obs, info = self.env.reset(seed=seed, options=options)
        return obs, self._with_left(info)

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._episode["reward"] += float(reward)
        self._episode["steps"] += 1
        if (terminated or truncated) and self._current is not None:
            self._write(terminated, truncated, info)
            self._current = None
        return obs, reward, terminated, truncated, self._with_left(info)

    def _with_left(self, info: dict) -> dict:
        return {**info, "scheduled_left": len(self.schedule) + (self._current is not None)}

    def _write(self, terminated: bool, truncated: bool, info: dict) -> None:
        assert self._current is not None
        board_id, rollout = self._current
        folder = self.runs_dir / board_id
        folder.mkdir(parents=True, exist_ok=True)
        raw = getattr(self.env, "raw_info", info)
        record = {"board_id": board_id, "rollout": rollout,
                  "time_s": time.perf_counter() - self._episode["began"],
                  "steps": self._episode["steps"], "reward": self._episode["reward"],
                  "terminated": bool(terminated), "truncated": bool(truncated),
                  "unconnected": raw.get("unconnected"), "drv": raw.get("drv"),
                  "engine_failure": raw.get("engine_failure"), "agent": self.agent,
                  "env_id": f"RLWrapper({self.env.unwrapped.options.config})"}  # type: ignore
        tmp = folder / f".{rollout}.tmp.kicad_pcb"
        try:
            self.env.unwrapped.save(str(tmp))  # type: ignore[attr-defined]
            os.replace(tmp, folder / f"{rollout}.kicad_pcb")
        except Exception as exc:  # noqa: BLE001 - a dead engine: the rollout has no board
            record["save_error"] = str(exc)
        write_atomic(folder / f"{rollout}.json", json.dumps(record, indent=1, sort_keys=True))

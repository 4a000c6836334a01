"""Agents for the rollout tests (importable by `--agent module:Class` in worker processes)."""
from __future__ import annotations

import os
import signal
import time
from pathlib import Path


class CrashingAgent:
    """Ends its process at the first action, as a policy that segfaults would."""

    def act(self, obs, info):
        os._exit(7)


class KillsItsRayWorkerOnce:
    """Scripted, but the first time it acts on a board (per rollout) it kills the Ray worker
    process whose KiCad worker runs the rollout, as when a node dies mid-task; Ray then runs
    the task again elsewhere. A file in the Ray test cluster's RAY_TEST_SCRATCH remembers it."""

    def __init__(self, seed: int = 0):
        from pcbdata.agents.scripted import ScriptedAgent

        self.seed, self.scripted = seed, ScriptedAgent(seed=seed)

    @property
    def done(self) -> bool:
        return self.scripted.done

    def act(self, obs, info):
        marker = Path(os.environ["RAY_TEST_SCRATCH"]) / f"killed-{info['board_id']}-{self.seed}"
        if not marker.exists():
            parent = Path(f"/proc/{os.getppid()}/cmdline").read_bytes()
            if b"ray::" not in parent:  # never the test process itself
                raise RuntimeError(f"not in a Ray worker: {parent[:80]!r}")
            marker.write_text("killed once")
            os.kill(os.getppid(), signal.SIGKILL)
            time.sleep(60)  # the worker dies with its parent (PR_SET_PDEATHSIG)
        return self.scripted.act(obs, info)


class StopsEarly:
    """`agent`, but done after `after` actions (or when `agent` is): an agent that ends its
    episode early, leaving whatever it drew (a random agent's dangling tracks and vias)."""

    def __init__(self, agent, after: int):
        self.agent, self.after, self.acted = agent, after, 0

    @property
    def done(self) -> bool:
        return bool(getattr(self.agent, "done", False)) or self.acted > self.after

    def act(self, obs, info):
        self.acted += 1
        return self.agent.act(obs, info)

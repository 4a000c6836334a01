"""The routing environment on a Ray cluster: environment workers as Ray actors.

    actors = make_actors(4, "pcbdata/Route-d2-v2", root="/shared/d2", split="test")
    episodes = step_episodes(actors, lambda seed: ScriptedAgent(seed=seed),
                             [("board_00000", 0), ("board_00001", 0), ...])
    close_actors(actors)

- `EnvActor` (a Ray actor, one CPU, on whichever node Ray places it) holds one
  `gym.make(env_id, **options)` environment, hence one KiCad worker process, a child of the
  actor's process that dies with it. Its methods (`reset`, `step`, `finish_episode`, `save`,
  `close`) return the environment's own values: dicts of numpy arrays and plain Python data,
  which pickle. An agent whose `done` turns True gets its episode ended by `finish_episode`
  (the final DRC's correction as the last reward, not counted as a step).
- `step_episodes` steps whole episodes on many actors at once from the driver, where the agent
  acts (as a learner's policy would): each actor takes the next episode when its last one
  ends, and each step is one round trip to the actor that holds the episode. The results are
  `Episode` records, the same as `run_episodes` gives on one local environment (the
  environment is deterministic: same board, seed and actions, same observations and rewards).
- An actor that dies (its node, `ray.kill`, the kernel's OOM killer) ends `step_episodes`
  with `EnvActorError` naming the actor, the board and the step: its episode's state was in
  that actor and is lost; run the episode again on a new actor (episodes are deterministic).

Ray is optional (`pip install 'pcbdata[ray]'`); it is imported only by `make_actors` and
`step_episodes`. Boards are read, and saved boards written, by the actors, at the paths given:
on a cluster of several machines, on a filesystem every node mounts at the same path.
"""
from __future__ import annotations

import hashlib
import os
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pcbdata.core.errors import EngineError

#: (board_id or None for the environment's seeded pick, seed) of one episode.
EpisodeSpec = tuple[str | None, int]
#: What `_Run` asks for when its agent is done: the environment's `finish_episode()`.
FINISH = "finish_episode"


class EnvActorError(EngineError):
    """An environment actor died (its node or process ended): its episode is lost."""

    label = "environment actor failed"


class EnvActor:
    """One routing environment (one KiCad worker process) in a Ray actor's process. Made by
    `make_actors` (`ray.remote(EnvActor)`); usable as a plain class too."""

    def __init__(self, env_id: str, options: dict[str, Any]):
        import gymnasium as gym

        import pcbdata.env  # noqa: F401 - registers the ids
        self.env: Any = gym.make(env_id, **options)

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        return self.env.reset(seed=seed, options=options)

    def step(self, action) -> tuple[dict, float, bool, bool, dict]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return obs, float(reward), bool(terminated), bool(truncated), info

    def finish_episode(self) -> tuple[dict, float, bool, bool, dict]:
        """Ends the episode early (`RoutingEnv.finish_episode`): its last transition."""
        obs, reward, terminated, truncated, info = self.env.unwrapped.finish_episode()
        return obs, float(reward), bool(terminated), bool(truncated), info

    def save(self, path: str) -> str:
        """Writes the current board (`RoutingEnv.save`) at `path`, as this actor's node sees it."""
        return self.env.unwrapped.save(path)

    def processes(self) -> dict[str, Any]:
        """This actor's process id and its children's (the environment's KiCad worker)."""
        return {"actor": os.getpid(), "children": child_processes(os.getpid())}

    def close(self) -> None:
        """Stops the environment's KiCad worker (the actor itself stays until killed)."""
        self.env.close()


def child_processes(pid: int) -> list[int]:
    """The children of process `pid` (every thread's), from /proc."""
    found: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found.update(int(c) for c in (task / "children").read_text().split())
        except OSError:  # the thread ended meanwhile
            continue
    return sorted(found)


def make_actors(count: int, env_id: str, address: str | None = None, num_cpus: float = 1,
                **options) -> list[Any]:
    """`count` `EnvActor`s on the Ray cluster at `address` (as `pcbdata.executors.connect`:
    the one this process joined, else `address`, else `RAY_ADDRESS`, else a new local Ray
    instance), each made with `gym.make(env_id, **options)`. The id and the options are checked
    here first, so a bad one is the environment's own error on the driver."""
    from pcbdata.executors import connect

    check_options(env_id, options)
    ray = connect(address)
    remote = ray.remote(num_cpus=num_cpus, max_restarts=0)(EnvActor)
    return [remote.remote(env_id, dict(options)) for _ in range(count)]


def check_options(env_id: str, options: dict[str, Any]) -> None:
    """Raises what `gym.make(env_id, **options)` would for an unknown id or a bad option."""
    import gymnasium as gym

    import pcbdata.env  # noqa: F401 - registers the ids
    from pcbdata.env.options import make_options
    from pcbdata.sets.configs import resolve_config

    spec = gym.spec(env_id)
    checked = make_options(**{**spec.kwargs, **options})
    resolve_config(checked.config, None if checked.rows is not None else checked.root)


def close_actors(actors: Sequence[Any], timeout: float = 30.0) -> None:
    """Closes every actor's environment (its KiCad worker ends), then ends the actors."""
    import ray

    # A dead actor's close() fails when waited on, not when sent: nothing to catch here.
    pending = [actor.close.remote() for actor in actors]
    ray.wait(pending, num_returns=len(pending), timeout=timeout)
    for actor in actors:
        ray.kill(actor)


# --- episodes ---------------------------------------------------------------------------------

@dataclass
class Episode:
    """One episode, as the driver saw it: a reward and an observation digest per step (the
    digest of the reset observation first). No wall time: the same episode gives the same
    record on any actor or locally."""

    board_id: str
    seed: int
    steps: int = 0
    reward: float = 0.0
    rewards: list[float] = field(default_factory=list)
    obs_digests: list[str] = field(default_factory=list)
    terminated: bool = False
    truncated: bool = False
    unconnected: int | None = None
    drv: int | None = None
    engine_failure: str | None = None
    saved: str | None = None


def observation_digest(obs) -> str:
    """sha256 of an observation's arrays (keys in order, dtype, shape and bytes of each)."""
    digest = hashlib.sha256()

    def feed(value, key: str) -> None:
        if isinstance(value, dict):
            for name in sorted(value):
                feed(value[name], f"{key}/{name}")
            return
        array = np.ascontiguousarray(value)
        digest.update(f"{key}:{array.dtype.str}:{array.shape};".encode())
        digest.update(array.tobytes())

    feed(obs, "")
    return digest.hexdigest()


class _Run:
    """One episode in progress: turns each (obs, ...) the environment returns into the next
    action, `FINISH` when the agent's `done` turns True (the episode is ended with
    `finish_episode()`, as `pcbdata.runners.rollout.run_episode` does), or None when the episode
    is over (terminated or truncated)."""

    def __init__(self, index: int, spec: EpisodeSpec, agent):
        self.index, self.agent = index, agent
        self.board, self.seed = spec
        self.record: Episode | None = None

    def reset_args(self) -> tuple[int, dict | None]:
        return self.seed, ({"board_id": self.board} if self.board is not None else None)

    def started(self, obs, info) -> Any:
        self.record = Episode(board_id=info["board_id"], seed=self.seed)
        return self._next(obs, info, False, False)

    def stepped(self, obs, reward: float, terminated: bool, truncated: bool, info,
                counted: bool = True) -> Any:
        """After a step (or, not `counted` as a step, after `finish_episode()`)."""
        record = self.episode()
        record.steps += int(counted)
        record.rewards.append(float(reward))
        record.reward += float(reward)
        return self._next(obs, info, terminated, truncated)

    def finished(self, transition) -> Any:
        """After `finish_episode()`: its transition, not counted as a step."""
        obs, reward, terminated, truncated, info = transition
        return self.stepped(obs, reward, terminated, truncated, info, counted=False)

    def _next(self, obs, info, terminated: bool, truncated: bool) -> Any:
        record = self.episode()
        record.obs_digests.append(observation_digest(obs))
        record.terminated, record.truncated = bool(terminated), bool(truncated)
        record.unconnected, record.drv = info["unconnected"], info["drv"]
        record.engine_failure = info.get("engine_failure")
        if terminated or truncated:
            return None
        act = self.agent.act(obs, info)
        return FINISH if getattr(self.agent, "done", False) else act

    def episode(self) -> Episode:
        assert self.record is not None, "started() comes first"
        return self.record

    def save_path(self, save_dir: str | None) -> str | None:
        if save_dir is None:
            return None
        return str(Path(save_dir).resolve() / self.episode().board_id / f"{self.seed}.kicad_pcb")


def run_episodes(env, agent_factory: Callable[[int], Any], episodes: Iterable[EpisodeSpec],
                 save_dir: str | None = None) -> list[Episode]:
    """The episodes on one local environment, one after the other: what `step_episodes` gives
    on actors (the reference it is tested against)."""
    out = []
    for index, spec in enumerate(episodes):
        run = _Run(index, spec, agent_factory(spec[1]))
        seed, options = run.reset_args()
        act = run.started(*env.reset(seed=seed, options=options))
        while act is not None:
            if act is FINISH:
                act = run.finished(env.unwrapped.finish_episode())
            else:
                act = run.stepped(*env.step(act))
        path = run.save_path(save_dir)
        if path is not None:
            run.episode().saved = env.unwrapped.save(path)
        out.append(run.episode())
    return out


def step_episodes(actors: Sequence[Any], agent_factory: Callable[[int], Any],
                  episodes: Iterable[EpisodeSpec], save_dir: str | None = None) -> list[Episode]:
    """Runs `episodes` ((board_id or None, seed) each) on `actors` (from `make_actors`), the
    agent (`agent_factory(seed)`, one per episode) acting on the driver; returns their
    `Episode` records in the order given. With `save_dir`, each episode's last board is saved
    by its actor as `save_dir/<board_id>/<seed>.kicad_pcb`."""
    import ray

    todo = deque(enumerate(episodes))
    results: dict[int, Episode] = {}
    idle = list(range(len(actors)))
    running: dict[Any, tuple[int, _Run, str]] = {}  # ref -> (actor, run, what was asked)
    while todo or running:
        while idle and todo:
            actor = idle.pop(0)
            index, spec = todo.popleft()
            run = _Run(index, spec, agent_factory(spec[1]))
            seed, options = run.reset_args()
            running[actors[actor].reset.remote(seed=seed, options=options)] = (actor, run, "reset")
        ready, _ = ray.wait(list(running), num_returns=1)
        for ref in ready:
            actor, run, asked = running.pop(ref)
            value = _get(ray, ref, actor, run, asked)
            act = _after(run, asked, value)
            if act is FINISH:
                running[actors[actor].finish_episode.remote()] = (actor, run, "finish")
                continue
            if act is not None:
                running[actors[actor].step.remote(act)] = (actor, run, "step")
                continue
            path = run.save_path(save_dir) if asked != "save" else None
            if path is not None:
                running[actors[actor].save.remote(path)] = (actor, run, "save")
                continue
            results[run.index] = run.episode()
            idle.append(actor)
    return [results[i] for i in sorted(results)]


def _after(run: _Run, asked: str, value) -> Any:
    """The next request of `run` once the actor answered `asked` with `value`."""
    if asked == "save":
        run.episode().saved = value
        return None
    if asked == "reset":
        return run.started(*value)
    return run.stepped(*value) if asked == "step" else run.finished(value)


def _get(ray, ref, actor: int, run: _Run, asked: str):
    """The value of `ref`; an actor that died is an `EnvActorError` naming it and the episode."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayActorError as exc:
        steps = run.record.steps if run.record is not None else 0
        text = str(exc).strip().splitlines()
        reason = f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__
        raise EnvActorError(f"environment actor {actor} died during {asked} (board "
                            f"{run.board or '(seeded pick)'}, seed {run.seed}, after {steps} "
                            f"steps): {reason}") from None

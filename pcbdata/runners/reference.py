"""Reference routings found by a bundled agent (`pcbdata build d2r --reference-agent`): the plan
the build carries and the worker task that routes one board. The build's side (which boards,
resume log, manifest) is `pcbdata.build.reference`.

A board is routed as `pcbdata rollout` routes it: the same environment options (its
defaults: a DRC after every step, the step limit per board), agent seeds 0, 1, ..., one
environment per worker. After each rollout the saved board is judged by the evaluator
(`measure` + `judge`, in this worker): the first one that is valid, a clean pass under both
counts (routability 1, DRV 0 and DRV+ 0) and has no DRC item of any other severity either
(what the build's KiCad check demands) is written as the reference; later seeds are not run.
"""
from __future__ import annotations

import shutil
from pathlib import Path

from pcbdata.build.reference import (
    ENGINE_FAILURE,
    NOT_COMPLETED,
    ROUTED,
    ReferencePlan,
)
from pcbdata.core.errors import UserError

#: The agents a build may route with: bundled, deterministic, offline. The best first.
AGENTS = ("negotiated", "scripted-shove", "scripted")
DEFAULT_AGENT = AGENTS[0]
#: As the benchmark's protocol (@5): the reference is within the agent's reach at k = 5.
DEFAULT_ROLLOUTS = 5
MAX_ROLLOUTS = 100
#: The routing environment's options: the default step limit, and KiCad's DRC once, at the end.
#: The bundled agents do not read the DRC, so an episode is the one `pcbdata rollout` runs
#: with its default DRC after every step, and its saved board the same bytes, at a fraction of
#: the time (`tests/builds/test_reference.py`).
ENV_OPTIONS = {"drc": "terminal", "max_steps": None}


def plan(agent: str = DEFAULT_AGENT, rollouts: int = DEFAULT_ROLLOUTS,
         splits: list[str] | tuple[str, ...] | None = None) -> ReferencePlan:
    """The plan of a build's reference routing (checked: a bad value is a `UserError`).
    `splits` None: validation and test, of the splits being built."""
    from pcbdata.env.registry import VERSION
    from pcbdata.runners.rollout import ROLLOUT_TIMEOUT
    from pcbdata.sets.configs import SYNTHETIC_SPLITS

    if agent not in AGENTS:
        raise UserError(f"--reference-agent {agent!r}: choose from {', '.join(AGENTS)}")
    if isinstance(rollouts, bool) or not isinstance(rollouts, int) \
            or not 1 <= rollouts <= MAX_ROLLOUTS:
        raise UserError(f"--reference-rollouts must be from 1 to {MAX_ROLLOUTS}, "
                        f"got {rollouts!r}")
    if splits is not None:
        bad = [s for s in splits if s not in SYNTHETIC_SPLITS]
        if bad or not splits:
            raise UserError(f"--reference-splits: unknown split {bad[0] if bad else '(none)'!r}; "
                            f"choose from {', '.join(SYNTHETIC_SPLITS)}")
        splits = tuple(s for s in SYNTHETIC_SPLITS if s in splits)
    return ReferencePlan(agent=agent, rollouts=rollouts, task=f"{__name__}:route_board",
                         env_version=VERSION, task_timeout=rollouts * ROLLOUT_TIMEOUT,
                         splits=splits, env_options=dict(ENV_OPTIONS))


def route_board(root: str, config: str, split: str, board_id: str, agent: str, rollouts: int,
                env_options: dict, target: str) -> dict:
    """Worker task: routes one board (seeds 0..rollouts-1, until one is clean) and writes the
    clean board to `target`. Returns the result: status `routed` (seed, sha256), else
    `not_completed` or `engine_failure` with the reason; always the environment id."""
    from pcbdata.agents.registry import make_agent
    from pcbdata.core.fsutil import owned_temp_folder, write_atomic
    from pcbdata.core.hashing import sha256_bytes
    from pcbdata.core.tree import BOARD_FILE, board_dir
    from pcbdata.env.registry import env_id_for
    from pcbdata.runners.rollout import run_episode, worker_env

    env_kwargs = {"id": env_id_for(config), "config": config, "root": root, "split": split,
                  **env_options}
    env = worker_env(env_kwargs)
    instance = board_dir(root, config, split, board_id)
    bare = _measured(instance / BOARD_FILE, instance)
    tries = []
    work = Path(owned_temp_folder("reference"))
    try:
        for seed in range(rollouts):
            record = run_episode(env, make_agent(agent, seed), board_id, seed)
            path = work / f"{seed}.kicad_pcb"
            env.unwrapped.save(str(path))
            problem = record.get("engine_failure") and f"engine failure: {record['engine_failure']}"
            problem = problem or _problem(bare, path, instance)
            if problem is None:
                data = path.read_bytes()
                write_atomic(target, data)
                return {"status": ROUTED, "seed": seed, "env_id": env_kwargs["id"],
                        "sha256": sha256_bytes(data)}
            tries.append((seed, record, problem))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {**_failed(tries, rollouts), "env_id": env_kwargs["id"]}


def _measured(board: Path, instance: Path) -> dict:
    from pcbdata.kicad.scoring import measure

    bare = measure(str(board), str(instance))
    if not bare.get("loaded"):
        raise RuntimeError(f"the instance cannot be measured: {bare.get('reason')}")
    return bare


def _problem(bare: dict, routed_file: Path, instance: Path) -> str | None:
    """Why a saved rollout is not a reference (None: it is), by the evaluator's judgement."""
    from pcbdata.evaluator.scorer import judge
    from pcbdata.kicad.scoring import measure

    routed = measure(str(routed_file), str(instance))
    record = judge(bare, routed)
    if record["status"] != "ok":
        return f"{record['status']}: {record['reason']}"
    if not (record["cp"] and record["cp_strict"]):
        return (f"{record['unconnected']} unconnected, DRV {record['drv']}, "
                f"DRV+ {record['drv_strict']}")
    others = sorted({v["type"] for v in routed["violations"] if v["severity"] != "excluded"})
    return f"DRC items left: {', '.join(others)}" if others else None


def _failed(tries: list[tuple[int, dict, str]], rollouts: int) -> dict:
    """The result of a board no rollout completed: an engine failure if any rollout had one
    (the board is tried again next run), else not completed, with the closest rollout."""
    failures = [problem for _, _, problem in tries if problem.startswith("engine failure")]
    if failures:
        return {"status": ENGINE_FAILURE, "seed": None, "reason": failures[0]}
    seed, record, problem = min(tries, key=lambda t: (t[1]["unconnected"], t[1]["drv"], t[0]))
    return {"status": NOT_COMPLETED, "seed": None,
            "reason": f"not completed in {rollouts} rollouts; closest: seed {seed}, {problem}"}

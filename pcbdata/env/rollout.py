"""Rollouts of an agent over a board set, written as `pcbdata eval` reads them:
`RUNS/<board_id>/<rollout>.kicad_pcb` + `<rollout>.json` (time_s, steps, reward, ...).

Parallel over worker processes (spawned; each owns one environment, hence one KiCad worker),
resumable (a rollout whose two files exist is skipped; files are written to temporary names
and renamed, the JSON last).
"""
from __future__ import annotations

import concurrent.futures as cf
import importlib
import inspect
import json
import multiprocessing
import multiprocessing.util
import os
import time
from pathlib import Path
from typing import Any

from pcbdata.errors import UserError

AGENTS = {"scripted": "pcbdata.env.agents:ScriptedAgent",
          "random": "pcbdata.env.agents:RandomAgent"}


def make_agent(spec: str, seed: int):
    """An agent by name (`scripted`, `random`) or `module:Class`; seeded when it takes one."""
    ref = AGENTS.get(spec, spec)
    module, _, name = ref.partition(":")
    if not name:
        raise UserError(f"--agent {spec!r}: use scripted, random or module:Class")
    try:
        cls = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise UserError(f"--agent {spec!r}: {exc}") from None
    takes_seed = "seed" in inspect.signature(cls).parameters
    return cls(seed=seed) if takes_seed else cls()


def run_episode(env, agent, board_id: str, seed: int) -> dict:
    """One episode from reset to its end (or until a scripted agent has nothing left to do)."""
    began = time.perf_counter()
    obs, info = env.reset(seed=seed, options={"board_id": board_id})
    total, steps, terminated, truncated = 0.0, 0, False, False
    while not (terminated or truncated):
        act = agent.act(obs, info)
        if getattr(agent, "done", False):
            break
        obs, reward, terminated, truncated, info = env.step(act)
        total += reward
        steps += 1
    return {"board_id": board_id, "rollout": seed, "time_s": time.perf_counter() - began,
            "steps": steps, "reward": total, "terminated": terminated, "truncated": truncated,
            "unconnected": info["unconnected"], "drv": info["drv"],
            "engine_failure": info.get("engine_failure")}


_ENV: dict[str, Any] = {}


def _env(env_kwargs: dict):
    import gymnasium as gym

    import pcbdata.env  # noqa: F401 - registers the ids
    if "env" not in _ENV:
        kwargs = dict(env_kwargs)
        _ENV["env"] = gym.make(kwargs.pop("id"), **kwargs)
        # Pool workers leave through os._exit: only multiprocessing's finalizers run.
        multiprocessing.util.Finalize(None, _ENV["env"].close, exitpriority=10)
    return _ENV["env"]


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def rollout_task(env_kwargs: dict, agent_spec: str, board_id: str, rollout: int,
                 out: str) -> dict:
    """Runs and writes one rollout (in a worker process)."""
    env = _env(env_kwargs)
    record = run_episode(env, make_agent(agent_spec, rollout), board_id, rollout)
    folder = Path(out) / board_id
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / f".{rollout}.tmp.kicad_pcb"
    try:
        env.unwrapped.save(str(tmp))
        os.replace(tmp, folder / f"{rollout}.kicad_pcb")
    except Exception as exc:  # noqa: BLE001 - a dead engine: the rollout has no board
        record["save_error"] = str(exc)
    record.update(agent=agent_spec, env_id=env_kwargs["id"])
    _write_atomic(folder / f"{rollout}.json", json.dumps(record, indent=1, sort_keys=True))
    return record


def pending(board_ids: list[str], rollouts: int, out: Path) -> list[tuple[str, int]]:
    """(board_id, rollout) pairs whose JSON is not written yet (the JSON is written last)."""
    return [(b, r) for b in board_ids for r in range(rollouts)
            if not (out / b / f"{r}.json").is_file()]


def run_rollouts(root, config: str, split: str, agent: str, rollouts: int, out, workers: int,
                 limit: int | None = None, env_options: dict | None = None, log=print) -> dict:
    """Runs every missing rollout; returns a summary. Progress lines go to `log`."""
    from pcbdata.env.registry import env_id
    from pcbdata.evaluator.runs import list_instances

    make_agent(agent, 0)  # a bad --agent fails before any work
    board_ids = [b for b, _ in list_instances(Path(root), config, split)][:limit]
    out = Path(out)
    todo = pending(board_ids, rollouts, out)
    env_kwargs = {"id": env_id(config), "root": str(root), "split": split, **(env_options or {})}
    began, records = time.perf_counter(), []
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(max_workers=max(1, min(workers, len(todo) or 1)),
                                mp_context=ctx) as pool:
        futures = [pool.submit(rollout_task, env_kwargs, agent, b, r, str(out)) for b, r in todo]
        for done, future in enumerate(cf.as_completed(futures), start=1):
            rec = future.result()
            records.append(rec)
            log(f"[{done}/{len(todo)}] {rec['board_id']} #{rec['rollout']}: {rec['steps']} steps,"
                f" reward {rec['reward']:.3f}, U {rec['unconnected']}, DRV {rec['drv']}, "
                f"{rec['time_s']:.2f} s" + (f", engine failure: {rec['engine_failure']}"
                                            if rec.get("engine_failure") else ""))
    return summarize(records, len(board_ids) * rollouts - len(todo), time.perf_counter() - began)


def summarize(records: list[dict], skipped: int, seconds: float) -> dict:
    n = len(records)
    return {"run": n, "skipped": skipped, "seconds": seconds,
            "terminated": sum(r["terminated"] for r in records),
            "mean_reward": sum(r["reward"] for r in records) / n if n else None,
            "mean_time_s": sum(r["time_s"] for r in records) / n if n else None,
            "engine_failures": sum(bool(r.get("engine_failure")) for r in records)}

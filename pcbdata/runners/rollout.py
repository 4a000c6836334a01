"""Rollouts of an agent over a board set, written as `pcbdata eval` reads them:
`RUNS/<board_id>/<rollout>.kicad_pcb` + `<rollout>.json` (time_s, steps, reward, ...).

One task per rollout, on an executor (`pcbdata.executors`): this machine's `KicadPool` worker
processes (the default) or a Ray cluster, where each Ray worker process runs its tasks in a
`KicadPool` worker of its own. Either way a worker (exec-started, with a time limit per
rollout) keeps one environment, hence one KiCad worker of its own, for all its rollouts.
Resumable (a rollout whose JSON exists is skipped; files are written to temporary names and
renamed, the JSON last), so a task run twice (Ray runs again a task whose node died) leaves
the same files. A rollout whose worker fails (time limit, crash) is reported and left pending.

The files are the same bytes whatever the executor and the worker (the environment is
deterministic and seeds KiCad's UUIDs), but for the JSON's `time_s`: the episode's wall time
(and, for the language-model agents, `llm.latency_s`; their moves are the server's).
"""
from __future__ import annotations

import atexit
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from pcbdata.agents.registry import make_agent


def run_episode(env, agent, board_id: str, seed: int) -> dict:
    """One episode from reset to its end. An agent whose `done` turns True (nothing left to
    do) ends it with `finish_episode()`: its last reward carries the final DRC's correction, so
    the summed reward is Phi of the saved board minus Phi of the bare one."""
    began = time.perf_counter()
    obs, info = env.reset(seed=seed, options={"board_id": board_id})
    attach = getattr(agent, "attach", None)
    if attach is not None:  # an agent that plans on the board's read-only view (negotiated)
        attach(env.unwrapped)
    total, steps, terminated, truncated = 0.0, 0, False, False
    while not (terminated or truncated):
        act = agent.act(obs, info)
        if getattr(agent, "done", False):
            obs, reward, terminated, truncated, info = env.unwrapped.finish_episode()
            total += reward
            break
        obs, reward, terminated, truncated, info = env.step(act)
        total += reward
        steps += 1
    record = {"board_id": board_id, "rollout": seed, "time_s": time.perf_counter() - began,
              "steps": steps, "reward": total, "terminated": terminated,
              "truncated": truncated, "unconnected": info["unconnected"], "drv": info["drv"],
              "engine_failure": info.get("engine_failure")}
    report = getattr(agent, "report", None)
    if report is not None:  # what the agent says of its episode (plain data: counts, causes)
        record["agent_report"] = report()
    return record


_ENV: dict[str, Any] = {}  # this worker's environment and the arguments it was made with


def worker_env(env_kwargs: dict):
    """This worker's environment for `env_kwargs`, made again when they change (a Ray node's
    worker outlives one run and may serve the next run's rollouts, with other options)."""
    import gymnasium as gym

    import pcbdata.env  # noqa: F401 - registers the ids
    if _ENV.get("kwargs") != env_kwargs:
        if "env" in _ENV:
            _ENV.pop("env").close()
        else:
            atexit.register(_close_env)  # the worker ends normally when its pool stops
        kwargs = dict(env_kwargs)
        _ENV["env"] = gym.make(kwargs.pop("id"), **kwargs)
        _ENV["kwargs"] = env_kwargs
    return _ENV["env"]


def _close_env() -> None:
    if "env" in _ENV:
        _ENV.pop("env").close()


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def agent_identity(spec: str, agent) -> dict:
    """Who made a rollout: `name` (the --agent given; `policy` for any checkpoint), `version`
    (pcbdata's for its own agents, else the agent class's `version` attribute, else None), and
    what the agent's `identity()` adds (a policy's checkpoint sha256 and sampling, a language
    model's model, server and sampling); None where it does not apply."""
    from pcbdata import __version__

    own = type(agent).__module__.startswith("pcbdata.")
    identity = {"name": "policy" if spec.startswith("policy:") else spec,
                "version": __version__ if own else getattr(agent, "version", None),
                "checkpoint_sha256": None, "model": None, "base_url": None,
                "prompt_version": None, "sampling": None}
    extra = getattr(agent, "identity", None)
    if callable(extra):
        identity.update(extra())
    return identity


def run_facts(env, agent, spec: str, seed: int, timeout: float | None) -> dict:
    """What a rollout's JSON records beside its outcome for `results.json`: the agent's
    identity, the seed, the environment's version, the budgets (the `max_steps` option,
    "default" for the per-board rule, the episode's `step_limit`, the DRC mode, the rollout's
    wall-time limit) and the machine (cores, CPU model, load at the rollout's end)."""
    from pcbdata.core.machine import machine_info
    from pcbdata.env.registry import VERSION

    base = env.unwrapped
    max_steps = base.options.max_steps
    return {"agent_identity": agent_identity(spec, agent), "seed": seed, "env_version": VERSION,
            "budgets": {"max_steps": "default" if max_steps is None else max_steps,
                        "step_limit": base.max_steps, "drc": base.options.drc,
                        "time_limit_s": timeout},
            "machine": machine_info()}


def rollout_task(env_kwargs: dict, agent_spec: str, board_id: str, rollout: int,
                 out: str, agent_options: dict | None = None,
                 timeout: float | None = None) -> dict:
    """Runs and writes one rollout (in a worker process). An agent with an `episode` method
    runs the whole episode itself (the language-model agents); one that sets `board_text`
    gives the rollout's board as text instead of the environment's board. `timeout` is the
    rollout's wall-time limit, recorded in its JSON."""
    env = worker_env(env_kwargs)
    agent = make_agent(agent_spec, rollout, agent_options)
    if hasattr(agent, "episode"):
        record = agent.episode(env, board_id, rollout, env_kwargs)
    else:
        record = run_episode(env, agent, board_id, rollout)
    folder = Path(out) / board_id
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / f".{rollout}.tmp.kicad_pcb"
    try:
        text = getattr(agent, "board_text", None)
        if text is None:
            env.unwrapped.save(str(tmp))
        else:
            _write_atomic(tmp, text)
        os.replace(tmp, folder / f"{rollout}.kicad_pcb")
    except Exception as exc:  # noqa: BLE001 - a dead engine: the rollout has no board
        record["save_error"] = str(exc)
    record.update(agent=agent_spec, env_id=env_kwargs["id"], config=env_kwargs["config"],
                  **run_facts(env, agent, agent_spec, rollout, timeout))
    _write_atomic(folder / f"{rollout}.json", json.dumps(record, indent=1, sort_keys=True))
    return record


def pending(board_ids: list[str], rollouts: int, out: Path) -> list[tuple[str, int]]:
    """(board_id, rollout) pairs whose JSON is not written yet (the JSON is written last)."""
    return [(b, r) for b in board_ids for r in range(rollouts)
            if not (out / b / f"{r}.json").is_file()]


#: Wall-time limit of one rollout (episode, save and JSON) in its worker.
ROLLOUT_TIMEOUT = 3600.0


def run_rollouts(root, config: str, split: str, agent: str, rollouts: int, out, workers: int,
                 limit: int | None = None, env_options: dict | None = None, log=print,
                 timeout: float = ROLLOUT_TIMEOUT, executor=None,
                 agent_options: dict | None = None) -> dict:
    """Runs every missing rollout, one task each on `executor` (None: this machine's workers,
    `workers` of them; a Ray executor uses every CPU of its cluster); returns a summary.
    Progress lines go to `log`. `root` and `out` are made absolute here: on a Ray cluster they
    must be the same path on every node (a shared filesystem). `agent_options` go to the agent
    (`make_agent`); an agent with a `preflight()` (a language model's server) is checked
    once here, before any work (a warning it returns goes to stderr)."""
    from pcbdata.core.tree import list_instances
    from pcbdata.env.registry import env_id_for
    from pcbdata.executors import resolve
    from pcbdata.sets.configs import resolve_config

    root, out = Path(root).resolve(), Path(out).resolve()
    resolve_config(config, root)  # any config the set holds; else a UserError naming them
    probe = make_agent(agent, 0, agent_options)  # a bad --agent fails before any work
    board_ids = [b for b, _ in list_instances(root, config, split)][:limit]
    todo = pending(board_ids, rollouts, out)
    if todo and hasattr(probe, "preflight"):
        warning = probe.preflight()
        if warning:
            print(f"pcbdata: warning: {warning}", file=sys.stderr)
    env_kwargs = {"id": env_id_for(config), "config": config, "root": str(root),
                  "split": split, **(env_options or {})}
    began, records, failed = time.perf_counter(), [], 0
    tasks = [(env_kwargs, agent, b, r, str(out), agent_options, timeout) for b, r in todo]
    with resolve(executor).pool(workers=max(1, min(workers, len(todo) or 1)),
                                task_timeout=timeout, tasks_per_worker=10**9,
                                memory_limit_mb=0) as pool:
        for done, outcome in enumerate(pool.map(f"{__name__}:rollout_task", tasks), start=1):
            if not outcome.ok:
                failed += 1
                board_id, rollout = todo[outcome.index]
                log(f"[{done}/{len(todo)}] {board_id} #{rollout}: failed: {outcome.error}")
                continue
            rec = outcome.value
            records.append(rec)
            log(f"[{done}/{len(todo)}] {rec['board_id']} #{rec['rollout']}: {_progress(rec)}")
    summary = summarize(records, len(board_ids) * rollouts - len(todo),
                        time.perf_counter() - began)
    summary["failed"] = failed
    return summary


def _progress(rec: dict) -> str:
    """A rollout's progress line (an open-loop copper agent has no reward: eval scores it)."""
    reward = "n/a" if rec["reward"] is None else f"{rec['reward']:.3f}"
    line = (f"{rec['steps']} steps, reward {reward}, U {rec['unconnected']}, DRV {rec['drv']}, "
            f"{rec['time_s']:.2f} s")
    if rec.get("engine_failure"):
        line += f", engine failure: {rec['engine_failure']}"
    end = (rec.get("llm") or {}).get("end")
    return line + (f", ended: {end}" if end else "")


def summarize(records: list[dict], skipped: int, seconds: float) -> dict:
    n = len(records)
    rewards = [r["reward"] for r in records if r["reward"] is not None]
    return {"run": n, "skipped": skipped, "seconds": seconds,
            "terminated": sum(r["terminated"] for r in records),
            "mean_reward": sum(rewards) / len(rewards) if rewards else None,
            "mean_time_s": sum(r["time_s"] for r in records) / n if n else None,
            "engine_failures": sum(bool(r.get("engine_failure")) for r in records)}

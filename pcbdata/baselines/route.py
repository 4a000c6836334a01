"""`pcbdata route`: routes the boards of one config/split with a baseline router.

Routers: `freeroute` (default) and any `--router-cmd` go through the Specctra round trip
(`pcbdata.baselines.specctra`); `kicad-tools` routes the `.kicad_pcb` directly
(`pcbdata.kicad.kicad_tools_route`). Each rollout runs in a `KicadPool` worker with a time limit.

Output: `OUT/<board_id>/<rollout>.kicad_pcb` and `<rollout>.json` (status, reason, router and
its version, `time_s` = wall time of the rollout, `router_s` and `router_cpu_s` of the router
process; `agent_identity`, `seed`, `budgets` and `machine` as `pcbdata rollout` writes them) - the
layout `pcbdata eval --runs` reads. Re-runs skip rollouts already routed.
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

from pcbdata.baselines import specctra
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import write_atomic
from pcbdata.core.machine import machine_info
from pcbdata.core.tree import BOARD_FILE
from pcbdata.kicad import kicad_tools_route as kicad_tools
from pcbdata.kicad.pool import KicadPool

ROUTERS = ("freeroute", "kicad-tools")


@dataclass(frozen=True)
class RolloutPlan:
    """How one rollout is routed: the worker task, its arguments after the board paths, and
    the labels recorded in the rollout's JSON."""

    task: str
    extra_args: tuple
    label: str
    version: str
    name: str = "freeroute"  # the router: freeroute, kicad-tools or router-cmd
    seed: int | None = None  # the router's seed, where it takes one (kicad-tools)


def rollout_plans(router: str, router_cmd: str | None, rollouts: int,
                  router_timeout: float) -> list[RolloutPlan]:
    if router == "kicad-tools" and not router_cmd:
        if kicad_tools.executable() is None:
            raise UserError("kicad-tools is not installed; run: pip install 'pcbdata[kicad-tools]'")
        seeds = [kicad_tools.SEEDS[r % len(kicad_tools.SEEDS)] for r in range(rollouts)]
        return [RolloutPlan("pcbdata.kicad.kicad_tools_route:route_board", (seed, router_timeout),
                            f"kicad-tools --seed {seed}", kicad_tools.version(), "kicad-tools",
                            seed) for seed in seeds]
    if router not in ROUTERS:
        raise UserError(f"unknown router {router!r}; "
                        f"use --router {' | '.join(ROUTERS)} or --router-cmd")
    plans = []
    for r in range(rollouts):
        argv, fix, label = specctra.router_command(router, router_cmd, r)
        version = specctra.freeroute_version() if fix else "unknown"
        route_args = (argv, router_timeout, fix, fix, fix, fix)
        plans.append(RolloutPlan(specctra.ROUTE, route_args, label, version,
                                 "router-cmd" if router_cmd else router))
    return plans


def route_set(root: str | Path, config: str, split: str, out: str | Path, router: str = "freeroute",
              router_cmd: str | None = None, rollouts: int = 1, workers: int = 1,
              router_timeout: float = 120.0, limit: int | None = None,
              progress: bool = True) -> dict:
    """Routes the boards of one config/split; returns counts {routed, failed, skipped}."""
    from pcbdata.core.tree import list_instances

    root, out = Path(root), Path(out)
    instances = list_instances(root, config, split)[: limit or None]
    plans = rollout_plans(router, router_cmd, rollouts, router_timeout)
    jobs: dict[str, list] = {}
    meta: dict[str, list] = {}
    skipped = 0
    for board_id, directory in instances:
        for r, plan in enumerate(plans):
            target = out / board_id / f"{r}.kicad_pcb"
            sidecar = target.with_suffix(".json")
            if sidecar.is_file():
                skipped += 1
                continue
            jobs.setdefault(plan.task, []).append(
                (str(directory / BOARD_FILE), str(directory), str(target), *plan.extra_args))
            meta.setdefault(plan.task, []).append((board_id, r, plan, sidecar))
    total = sum(len(j) for j in jobs.values())
    if progress:
        print(f"pcbdata route: {total} rollouts to route ({skipped} already done)", file=sys.stderr)
    counts = {"routed": 0, "failed": 0, "skipped": skipped}
    with KicadPool(workers=workers, task_timeout=router_timeout + 120) as pool:
        done = 0
        for task, task_jobs in jobs.items():
            for outcome in pool.map(task, task_jobs):
                board_id, r, plan, sidecar = meta[task][outcome.index]
                record = _record(board_id, r, plan, outcome, router_timeout)
                counts[record["status"]] += 1
                write_atomic(sidecar, json.dumps(record, indent=1, sort_keys=True) + "\n")
                done += 1
                if progress and (done % 25 == 0 or done == total):
                    print(f"  routed {done}/{total}", file=sys.stderr)
    return counts


def _record(board_id: str, rollout: int, plan: RolloutPlan, outcome,
            router_timeout: float) -> dict:
    """A rollout's JSON: outcome and times, and for `results.json` the router as the agent
    (name, version), its seed, the time limit and the machine."""
    value = outcome.value if outcome.ok else {"ok": False, "reason": outcome.error}
    version = None if plan.version == "unknown" else plan.version
    return {"board_id": board_id, "rollout": rollout, "router": plan.label,
            "router_version": plan.version,
            "agent_identity": {"name": plan.name, "version": version,
                               "checkpoint_sha256": None, "model": None, "base_url": None,
                               "prompt_version": None, "sampling": None},
            "seed": plan.seed,
            "budgets": {"max_steps": None, "step_limit": None, "drc": None,
                        "time_limit_s": router_timeout},
            "machine": machine_info(),
            "status": "routed" if value.get("ok") else "failed",
            "reason": value.get("reason", ""),
            "time_s": value.get("seconds", outcome.seconds),
            "router_s": value.get("router_seconds"),
            "router_cpu_s": value.get("router_cpu_seconds")}

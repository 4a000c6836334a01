"""Baseline routing through a Specctra round trip (`pcbdata route`).

KiCad exports each instance as a Specctra DSN file, a router turns it into an SES session, and
KiCad imports the session and saves the routed board (`pcbdata.kicad.specctra`). The default
router is `freeroute` (pure Python, from PyPI: `pip install freeroute`); any command that reads
DSN and writes SES can be plugged in with `--router-cmd`, e.g.
`--router-cmd "java -jar freerouting.jar -de {dsn} -do {ses} -mp 20"`.

Output: `OUT/<board_id>/<rollout>.kicad_pcb` and `<rollout>.json` (time_s, router, status) -
the layout `pcbdata eval --runs` reads. Re-runs skip rollouts already routed.
"""
from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

from pcbdata.errors import UserError
from pcbdata.fsutil import write_atomic
from pcbdata.kicad.pool import KicadPool

ROUTE = "pcbdata.kicad.specctra:route_board"
#: freeroute options per rollout (cycled): rollout 0 is the package's most DRC-careful engine.
FREEROUTE_VARIANTS = (
    ("--engine", "exact", "--shove", "--diagonal"),
    ("--engine", "room", "--pack", "--shove"),
    ("--engine", "exact"),
    ("--engine", "grid"),
    ("--engine", "exact", "--shove", "--diagonal", "-mp", "20"),
)


def freeroute_available() -> bool:
    """Whether freeroute is installed. It only ever runs as a separate process (`python -m
    freeroute.cli`), never imported into pcbdata (it is GPL-3.0-or-later, pcbdata is MIT)."""
    import importlib.util

    return importlib.util.find_spec("freeroute") is not None


def router_command(router: str, router_cmd: str | None,
                   rollout: int) -> tuple[list[str], bool, str]:
    """(argv with {dsn}/{ses} placeholders, whether to apply the freeroute work-arounds, label)."""
    if router_cmd:
        argv = shlex.split(router_cmd)
        if "{dsn}" not in router_cmd or "{ses}" not in router_cmd:
            raise UserError("--router-cmd must contain {dsn} and {ses}, e.g. "
                            "'java -jar freerouting.jar -de {dsn} -do {ses}'")
        return argv, False, router_cmd
    if router != "freeroute":
        raise UserError(f"unknown router {router!r}; use --router freeroute or --router-cmd")
    if not freeroute_available():
        raise UserError("freeroute is not installed; run: pip install freeroute "
                        "(or give --router-cmd)")
    variant = list(FREEROUTE_VARIANTS[rollout % len(FREEROUTE_VARIANTS)])
    argv = [sys.executable, "-m", "freeroute.cli", "{dsn}", "-o", "{ses}", *variant]
    return argv, True, "freeroute " + " ".join(variant)


def route_set(root: str | Path, config: str, split: str, out: str | Path, router: str = "freeroute",
              router_cmd: str | None = None, rollouts: int = 1, workers: int = 1,
              router_timeout: float = 120.0, limit: int | None = None,
              progress: bool = True) -> dict:
    """Routes the boards of one config/split; returns counts {routed, failed, skipped}."""
    from pcbdata.evaluator.runs import list_instances

    root, out = Path(root), Path(out)
    instances = list_instances(root, config, split)[: limit or None]
    commands = [router_command(router, router_cmd, r) for r in range(rollouts)]
    jobs, meta, skipped = [], [], 0
    for board_id, directory in instances:
        for r, (argv, fix, label) in enumerate(commands):
            target = out / board_id / f"{r}.kicad_pcb"
            sidecar = target.with_suffix(".json")
            if sidecar.is_file():
                skipped += 1
                continue
            jobs.append((str(directory / "board.kicad_pcb"), str(directory), str(target), argv,
                         router_timeout, fix, fix))
            meta.append((board_id, r, label, sidecar))
    counts = {"routed": 0, "failed": 0, "skipped": skipped}
    if progress:
        print(f"pcbdata route: {len(jobs)} rollouts to route ({skipped} already done)",
              file=sys.stderr)
    with KicadPool(workers=workers, task_timeout=router_timeout + 120) as pool:
        for n, outcome in enumerate(pool.map(ROUTE, jobs), start=1):
            board_id, r, label, sidecar = meta[outcome.index]
            value = outcome.value if outcome.ok else {"ok": False, "reason": outcome.error}
            record = {"board_id": board_id, "rollout": r, "router": label,
                      "status": "routed" if value.get("ok") else "failed",
                      "reason": value.get("reason", ""),
                      "time_s": value.get("seconds", outcome.seconds),
                      "router_s": value.get("router_seconds")}
            counts["routed" if value.get("ok") else "failed"] += 1
            write_atomic(sidecar, json.dumps(record, indent=1, sort_keys=True) + "\n")
            if progress and (n % 25 == 0 or n == len(jobs)):
                print(f"  routed {n}/{len(jobs)}", file=sys.stderr)
    return counts

"""Benchmark of the routing environment: the scripted agent over the D2 test boards.

For DRC after every copper-changing step and for terminal-only DRC: median episode wall time
(reset included), steps per second, the walkaround router's call times; then CP @1 of the
scripted agent by `pcbdata eval` on its saved boards. Boards come from the generator (the same
bytes `pcbdata build d2` writes) unless --set is given. Uses the walkaround mode when the
walkaround router is installed, else mark_obstacles (said in the output).

    .venv/bin/python bench/bench_env.py [--set SET] [--limit N] [--json bench/runs/env.json]
        [--preload LIB]   # e.g. the LD_PRELOAD library of the drcwait branch
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def _write_set(root: Path, limit: int) -> None:
    from pcbdata.testing.sets import write_set

    write_set(root, "d2", "test", limit)


def _episodes(root: Path, config: str, drc: str, limit: int, mode: int, preload: str | None,
              runs: Path | None, seed: int = 0) -> dict:
    import pcbdata.env
    from pcbdata.agents.scripted import ScriptedAgent
    from pcbdata.runners.rollout import run_episode

    engine_env = {"LD_PRELOAD": preload} if preload else None
    env = pcbdata.env.make(root, config, split="test", drc=drc, engine_env=engine_env)
    env.reset(seed=0)  # the worker's start-up is not an episode's time
    times, steps, records = [], 0, []
    for board_id in env.unwrapped.source.board_ids[:limit]:
        record = run_episode(env, ScriptedAgent(seed=seed, mode=mode), board_id, seed)
        times.append(record["time_s"])
        steps += record["steps"]
        records.append(record)
        if runs is not None:
            (runs / board_id).mkdir(parents=True, exist_ok=True)
            env.unwrapped.save(runs / board_id / f"{seed}.kicad_pcb")
            (runs / board_id / f"{seed}.json").write_text(json.dumps(record))
    router = env.unwrapped.timings["router_s"]
    env.close()
    return {"drc": drc, "episodes": len(times), "median_episode_s": statistics.median(times),
            "mean_episode_s": statistics.mean(times), "steps": steps,
            "steps_per_s": steps / sum(times),
            "fully_connected": sum(r["terminated"] for r in records),
            "router_calls": len(router),
            "router_median_ms": 1e3 * statistics.median(router) if router else None,
            "router_p90_ms": (1e3 * sorted(router)[int(0.9 * (len(router) - 1))]
                              if router else None),
            "router_max_ms": 1e3 * max(router) if router else None}


def main() -> int:
    from _measure import machine, report

    from pcbdata.env.types import MARK_OBSTACLES, MODES, WALKAROUND
    from pcbdata.evaluator.runs import evaluate_set

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", help="a built set holding <config>/test (default: generated)")
    parser.add_argument("--config", default="d2", help="d2 (default), d3-a, d3-b, ...")
    parser.add_argument("--skip-step-drc", action="store_true",
                        help="only terminal DRC (D3: DRC of real boards after every step is slow)")
    parser.add_argument("--limit", type=int, default=128)
    parser.add_argument("--preload", help="LD_PRELOAD for the KiCad worker")
    parser.add_argument("--k", type=int, default=5,
                        help="rollouts per board for CP @k (the extra ones with terminal DRC: "
                             "the scripted agent does not read the DRC, its boards are the same)")
    parser.add_argument("--mark-obstacles", action="store_true",
                        help="the scripted agent in mark_obstacles mode (engine speed only)")
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()
    mode = MARK_OBSTACLES if args.mark_obstacles else WALKAROUND
    with tempfile.TemporaryDirectory(prefix="bench-env-") as tmp:
        root = Path(args.set) if args.set else Path(tmp) / "set"
        if not args.set:
            if args.config != "d2":
                parser.error("--set is needed for configs other than d2")
            _write_set(root, args.limit)
        runs = Path(tmp) / "runs"
        load_before = os.getloadavg()
        skip = args.skip_step_drc
        per_step = None if skip else _episodes(root, args.config, "step", args.limit, mode,
                                               args.preload, runs)
        terminal = _episodes(root, args.config, "terminal", args.limit, mode, args.preload,
                             runs if skip else None)
        for seed in range(1, args.k):
            _episodes(root, args.config, "terminal", args.limit, mode, args.preload, runs, seed)
        summary = evaluate_set(root, args.config, "test", Path(tmp) / "report", runs=runs, k=1,
                               workers=2, progress=False, limit=args.limit)
        at_k = evaluate_set(root, args.config, "test", Path(tmp) / "report_k", runs=runs,
                            k=args.k, workers=2, progress=False, limit=args.limit)
    result = {"machine": machine(), "date": datetime.now(UTC).isoformat(timespec="minutes"),
              "load_before": load_before, "load_after": os.getloadavg(), "mode": MODES[mode],
              "preload": args.preload, "ld_preload": os.environ.get("LD_PRELOAD"),
              "config": args.config, "drc_every_step": per_step, "drc_terminal": terminal,
              "eval_at_1": summary["summary"], "eval_table": summary["table"],
              f"eval_at_{args.k}": at_k["summary"], "eval_table_at_k": at_k["table"]}
    report(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""D1 rows of a grid-action policy: greedy rollouts in Jumanji's own Connector, converted to
boards (`pcbdata convert-connector`'s library call) and scored by `pcbdata eval`.

Builds the first N test boards of each D1 grid (`pcbdata build d1 --no-check`: the same boards
as `bench/bench_d1.py`), feeds the split's Connector arrays into Jumanji's Connector
(`pcbdata.baselines.connector_jumanji`), plays the greedy policy (a breadth-first path per agent
in turn, then all agents move along their paths), converts the final grids and scores them
(@1: the policy is deterministic). One row per grid: boards, walled-in boards, CP, Rout.,
Jumanji's own connected share (must equal Rout.), mean seconds per episode (planning and
Jumanji steps, jit compilation excluded).

    python bench/bench_connector.py --limit 16 --grids 10,50
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

GRIDS = (10, 50, 100, 200, 500)
AGENT = "jumanji-greedy"


def _build(root: Path, grid: int, limit: int, workers: int) -> None:
    from pcbdata.cli import main as pcbdata

    code = pcbdata(["build", "d1", "--grid", str(grid), "--splits", "test", "--count", str(limit),
                    "--no-check", "--workers", str(workers), "--out", str(root)])
    if code:
        raise SystemExit(f"build d1 --grid {grid} failed with exit code {code}")


def _grid(root: Path, work: Path, grid: int, args) -> dict:
    import numpy as np
    from bench_d1 import _walled_boards

    from pcbdata.baselines.connector import convert_rollouts
    from pcbdata.baselines.connector_jumanji import rollout_split
    from pcbdata.evaluator.runs import evaluate_set

    config = f"d1-g{grid}"
    _build(root, grid, args.limit, args.workers)
    result = rollout_split(root, config, "test", limit=args.limit)
    solutions = work / f"greedy-{config}.npz"
    np.savez_compressed(solutions, grids=result["grids"].astype(np.int16),
                        board_ids=result["board_ids"], time_s=result["time_s"])
    runs, report = work / f"runs-{AGENT}-{config}", work / f"report-{AGENT}-{config}"
    convert_rollouts(root, config, "test", solutions, runs)
    scored = evaluate_set(root, config, "test", report, runs=runs, k=1, workers=args.workers,
                          progress=False, limit=args.limit)
    s = scored["summary"]
    return {"config": config, "agent": AGENT, "boards": args.limit,
            "walled_in": _walled_boards(config, args.limit), "cp": s["cp"], "rout": s["rout"],
            "jumanji_connected": float(np.mean(result["ratio_connections"])),
            "episode_s": float(np.mean(result["time_s"])), "drv": s["drv"], "wl": s["wl"]}


def _table(rows: list[dict]) -> str:
    lines = ["| agent | grid | boards | walled in | CP @1 (%) | Rout. @1 | Jumanji connected "
             "| s / episode |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['agent']} | {r['config']} | {r['boards']} | {r['walled_in']} | "
                     f"{100 * r['cp']:.1f} | {r['rout']:.3f} | {r['jumanji_connected']:.3f} | "
                     f"{r['episode_s']:.3f} |")
    return "\n".join(lines)


def main() -> int:
    from _measure import machine

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=16, help="test boards per grid")
    parser.add_argument("--workers", type=int, default=2, help="build and evaluator workers")
    parser.add_argument("--grids", default=",".join(map(str, GRIDS)), help="D1 grid sizes")
    parser.add_argument("--keep", help="keep boards, solutions, runs and reports in this folder")
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()
    load_before = Path("/proc/loadavg").read_text().strip()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-connector-") as tmp:
        work = Path(args.keep) if args.keep else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for grid in (int(g) for g in args.grids.split(",")):
            rows.append(_grid(work / "set", work, grid, args))
            print(_table(rows[-1:]).splitlines()[-1], flush=True)
    result = {"machine": machine(), "date": datetime.now(UTC).isoformat(timespec="minutes"),
              "load_before": load_before, "load_after": Path("/proc/loadavg").read_text().strip(),
              "workers": args.workers, "rows": rows}
    print(_table(rows))
    print(f"{result['date']}  {result['machine']}  load before {load_before}, "
          f"after {result['load_after']}  (cpus: {os.cpu_count()})")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())

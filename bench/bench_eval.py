"""Benchmark: `pcbdata eval` versus one `kicad-cli pcb drc` per board, side by side.

Scores every rollout of a submission with the evaluator (fresh report folder, no cache, worker
start-up included), then runs one `kicad-cli pcb drc --all-track-errors --severity-all` per
rollout (the same staging: the routed board next to the instance's project) with the same
number of parallel processes, and checks that both give identical counts per rollout (DRV,
unconnected items and counted violations per type).

    .venv/bin/python bench/bench_eval.py --set SET --config d2 --split test --runs RUNS \
        --json bench-eval.json

The evaluator's time includes starting its workers and measuring the 128 bare instances.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pcbdata.core.tree import list_instances  # noqa: E402
from pcbdata.evaluator.metrics import COUNTED_WARNINGS  # noqa: E402
from pcbdata.evaluator.runs import evaluate_set, list_rollouts  # noqa: E402
from pcbdata.kicad.cli_tools import kicad_cli  # noqa: E402


def cli_counts(instance: Path, routed: Path) -> dict:
    """DRV, U and counted types from one kicad-cli DRC run with the instance's project."""
    with tempfile.TemporaryDirectory(prefix="bench-cli-") as tmp:
        board = Path(tmp) / "scored.kicad_pcb"
        shutil.copyfile(routed, board)
        for suffix in (".kicad_pro", ".kicad_dru"):
            if (instance / f"board{suffix}").is_file():
                shutil.copyfile(instance / f"board{suffix}", Path(tmp) / f"scored{suffix}")
        report = Path(tmp) / "drc.json"
        subprocess.run([kicad_cli(), "pcb", "drc", "--all-track-errors", "--severity-all",
                        "--format", "json", "--output", str(report), str(board)],
                       check=True, capture_output=True, timeout=600)
        data = json.loads(report.read_text())
    by_type: dict[str, int] = {}
    for v in data.get("violations", []):
        if v.get("excluded") or v["severity"] == "exclusion":
            continue
        if v["severity"] == "error" or (v["severity"] == "warning"
                                        and v["type"] in COUNTED_WARNINGS):
            by_type[v["type"]] = by_type.get(v["type"], 0) + 1
    unconnected = [v for v in data.get("unconnected_items", []) if not v.get("excluded")]
    for v in unconnected:
        by_type[v["type"]] = by_type.get(v["type"], 0) + 1
    return {"drv": sum(by_type.values()), "unconnected": len(unconnected),
            "drv_by_type": dict(sorted(by_type.items()))}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", required=True, help="built board set")
    parser.add_argument("--config", default="d2")
    parser.add_argument("--split", default="test")
    parser.add_argument("--runs", required=True, help="RUNS/<board_id>/<rollout>.kicad_pcb")
    parser.add_argument("--k", type=int, default=5)
    parser.add_argument("--workers", type=int, default=min(32, 8 * (os.cpu_count() or 1)),
                        help="evaluator KiCad workers (default: as `pcbdata eval`)")
    parser.add_argument("--cli-workers", type=int, default=os.cpu_count() or 1,
                        help="parallel kicad-cli processes (default: one per core)")
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="bench-eval-") as report:
        start = time.perf_counter()
        result = evaluate_set(args.set, args.config, args.split, report, runs=args.runs, k=args.k,
                              workers=args.workers, progress=False)
        eval_seconds = time.perf_counter() - start
    rows = {(r["board_id"], r["rollout"]): r for r in result["rollouts"]}
    pairs = []
    for board_id, directory in list_instances(Path(args.set), args.config, args.split):
        for rollout, path in list_rollouts(Path(args.runs), board_id, args.k):
            pairs.append(((board_id, rollout), directory, path))
    scored = [p for p in pairs if rows[p[0]]["status"] == "ok"]

    start = time.perf_counter()
    with ThreadPoolExecutor(max_workers=args.cli_workers) as pool:
        cli = list(pool.map(lambda p: cli_counts(p[1], p[2]), scored))
    cli_seconds = time.perf_counter() - start

    mismatches = []
    for (key, _, _), counts in zip(scored, cli):
        mine = rows[key]  # cli_counts counts the three warnings: the strict count
        if (mine["drv_strict"], mine["unconnected"], mine["drv_strict_by_type"]) != (
                counts["drv"], counts["unconnected"], counts["drv_by_type"]):
            mismatches.append({"rollout": "/".join(key), "evaluator": {
                "drv_strict": mine["drv_strict"], "unconnected": mine["unconnected"],
                "drv_strict_by_type": mine["drv_strict_by_type"]}, "kicad_cli": counts})
    figures = {
        "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": f"{os.cpu_count()} cores, {platform.machine()}, 1-min load average at the end "
                   f"{os.getloadavg()[0]:.1f}",
        "config": args.config, "split": args.split, "k": args.k, "workers": args.workers,
        "cli_workers": args.cli_workers,
        "rollouts": len(pairs), "scored_rollouts": len(scored),
        "evaluator_seconds": round(eval_seconds, 2),
        "kicad_cli_seconds": round(cli_seconds, 2),
        "evaluator_boards_per_second": round(len(pairs) / eval_seconds, 1),
        "kicad_cli_boards_per_second": round(len(scored) / cli_seconds, 1),
        # per-rollout throughput ratio (kicad-cli only runs on the rollouts that load)
        "speedup": round((len(pairs) / eval_seconds) / (len(scored) / cli_seconds), 1)
        if scored and eval_seconds else None,
        "identical_counts": not mismatches,
        "mismatches": mismatches[:10],
        "n_mismatches": len(mismatches),
        "summary": result["summary"],
    }
    text = json.dumps(figures, indent=1, sort_keys=True)
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n")
    return 0 if not mismatches else 1


if __name__ == "__main__":
    sys.exit(main())

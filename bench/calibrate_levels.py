r"""Calibrates the D2 levels by the baseline routers: CP should fall with rank.

For every D2 level of the registry: build N test boards (no KiCad check: the boards are
pinned by the golden tests), route them with each router (`pcbdata route`), score @1 and @k
(`pcbdata eval`), and print one table row per level and router: CP @1 and @k, Rout., DRV, WL,
Via @k and the median router wall and CPU seconds per board. Writes
`bench/runs/levels.json` with machine, date and load.

    .venv/bin/python bench/calibrate_levels.py --boards 64 --rollouts 5 \
        [--routers freeroute,kicad-tools]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import machine  # noqa: E402

from pcbdata.baselines.route import route_set  # noqa: E402
from pcbdata.cli import main as cli  # noqa: E402
from pcbdata.evaluator.runs import evaluate_set  # noqa: E402
from pcbdata.sets.configs import registry  # noqa: E402


def level_row(root: Path, config: str, router: str, boards: int, rollouts: int,
              workers: int) -> dict:
    runs = root / f"runs-{config}-{router}"
    route_set(root, config, "test", runs, router=router, rollouts=rollouts, workers=workers,
              limit=boards, progress=False)
    # One report folder for both: its score cache means the @k pass scores only the rollouts
    # the @1 pass did not (the files of the @1 report are overwritten; its summary is kept).
    report = root / f"report-{config}-{router}"
    at1 = evaluate_set(root, config, "test", report, runs=runs, k=1,
                       workers=4 * workers, limit=boards, progress=False)["summary"]
    atk = evaluate_set(root, config, "test", report, runs=runs,
                       k=rollouts, workers=4 * workers, limit=boards, progress=False)["summary"]
    metas = [json.loads(p.read_text()) for p in runs.glob("*/*.json")]
    return {"config": config, "router": router, "cp_at1": at1["cp"], "cp_atk": atk["cp"],
            "rout": atk["rout"], "drv": atk["drv"], "drv_at1": at1["drv"], "wl": atk["wl"],
            "via": atk["via"], "k": rollouts, "boards": boards,
            "median_router_s": statistics.median(m["router_s"] or 0 for m in metas),
            "median_router_cpu_s": statistics.median(m.get("router_cpu_s") or 0 for m in metas)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boards", type=int, default=64)
    parser.add_argument("--rollouts", type=int, default=5)
    parser.add_argument("--routers", default="freeroute")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default=str(Path(__file__).parent / "runs" / "levels.json"))
    args = parser.parse_args()
    levels = [s for s in registry().values() if s.family == "d2"]
    rows, started = [], time.time()
    with tempfile.TemporaryDirectory(prefix="pcbdata-levels-") as tmp:
        root = Path(tmp) / "set"
        for spec in levels:
            build = ["build", "d2", "--level", spec.level, "--splits", "test", "--count",
                     str(args.boards), "--no-check", "--out", str(root)]
            if cli(build) != 0:
                return 1
            for router in args.routers.split(","):
                rollouts = args.rollouts if router == "freeroute" else 1
                row = level_row(root, spec.name, router, args.boards, rollouts, args.workers)
                row["rank"] = spec.rank
                rows.append(row)
                print(json.dumps(row), flush=True)
    print("\n| level | rank | router | CP @1 (%) | CP @k (%) | Rout. @k | DRV @1 | DRV @k "
          "| WL @k (mm) | Via @k | router s/board (median) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['config']} | {r['rank']} | {r['router']} (k={r['k']}) | "
              f"{100 * r['cp_at1']:.1f} | "
              f"{100 * r['cp_atk']:.1f} | {r['rout']:.3f} | {r['drv_at1']:.2f} | {r['drv']:.2f} | "
              f"{r['wl']:.1f} | {r['via']:.2f} | {r['median_router_s']:.2f} |")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"machine": machine(),
                                          "date": time.strftime("%Y-%m-%d %H:%M UTC",
                                                                time.gmtime()),
                                          "load": os.getloadavg(),
                                          "seconds": time.time() - started,
                                          "rows": rows}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

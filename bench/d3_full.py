"""Times one full `pcbdata build d3` (wall time, peak memory of the whole process tree).

    .venv/bin/python bench/d3_full.py --source PCBENCH_DIR --out DIR [--workers 2]

Results: bench/runs/d3_full.json (plus the build's own fate and tier summary).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _measure import machine, run_measured  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--source", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--results", type=Path, default=HERE / "runs" / "d3_full.json")
    args = parser.parse_args()
    run = run_measured([sys.executable, "-m", "pcbdata", "build", "d3", "--quiet", "--source",
                        args.source, "--out", args.out, "--workers", str(args.workers)],
                       cwd=HERE.parent)
    report = json.loads((Path(args.out) / "curation_report.json").read_text())
    result = {"machine": machine(), "workers": args.workers,
              "seconds": round(run["seconds"], 1), "peak_mib": round(run["peak_mib"]),
              "fates": report["fates"], "tiers": report["tiers"]}
    args.results.parent.mkdir(parents=True, exist_ok=True)
    args.results.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()

"""`pcbdata build d3`: rebuild the curated real-board set from a PCBench checkout."""
from __future__ import annotations

from pcbdata.cli import _checks as checks
from pcbdata.cli import _executor_options

FAMILY = "d3"
HELP = "curate the D3 real-board set (tiers D3-A/B/C) from a PCBench checkout"


def register(parser) -> None:
    parser.add_argument("--source", required=True, metavar="PCBENCH_DIR",
                        help="a PCBench checkout (holds PCBs/ and github_meta/)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--workers", type=checks.workers, default=None, metavar="N",
                        help="KiCad worker processes (default: number of CPUs)")
    parser.add_argument("--recipe", default=None, metavar="PATH",
                        help="recipe TOML (default: the packaged "
                             "pcbdata/resources/recipes/d3.toml)")
    parser.add_argument("--tasks-per-worker", type=checks.positive, default=20, metavar="N",
                        help="recycle a KiCad worker after N boards (memory; default 20)")
    parser.add_argument("--quiet", action="store_true", help="only print the summary")
    _executor_options.add(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    import sys

    from pcbdata.build import build_d3

    log = (lambda line: None if not line.startswith("d3:") else
           print(line, file=sys.stderr, flush=True)) if args.quiet else None
    summary = build_d3(args.source, args.out, args.recipe, workers=args.workers,
                       tasks_per_worker=args.tasks_per_worker, log=log,
                       executor=_executor_options.executor(args))
    print("fates: " + ", ".join(f"{k}={v}" for k, v in summary["fates"].items()))
    print("tiers: " + ", ".join(f"{c}={n['full']} test={n['test']}"
                                for c, n in summary["tiers"].items()))
    print(f"wrote {args.out} in {summary['wall_seconds']} s")
    return 0

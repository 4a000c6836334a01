"""`pcbdata leaderboard`: check results files and compare them in tables and a static site."""
from __future__ import annotations

from pcbdata.cli import _checks as checks

VERB = "leaderboard"
HELP = ("check results files (pcbdata eval's results.json) and compare them: leaderboard.md "
        "and a static site (index.html)")


def register(parser) -> None:
    parser.add_argument("results", nargs="+", metavar="RESULTS",
                        help="results files (results.json of pcbdata eval reports)")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="site folder: index.html, leaderboard.md, files/<name>/ (a new or "
                             "empty folder, or a site written before, which is replaced)")
    parser.add_argument("--rescore", action="store_true",
                        help="score every file's boards again (its set and runs folders) and "
                             "refuse a file whose figures they do not give")
    parser.add_argument("--set", metavar="SET", dest="set_root",
                        help="with --rescore: the set folder, instead of the one the files name")
    parser.add_argument("--runs", metavar="RUNS",
                        help="with --rescore: the runs folder, instead of the one the files name")
    parser.add_argument("--workers", type=checks.workers, default=2,
                        help="KiCad worker processes for rescoring and pictures (default: 2)")
    parser.add_argument("--timeout", type=checks.seconds, default=300.0,
                        help="seconds allowed per board when rescoring (default: 300)")
    parser.add_argument("--no-pictures", action="store_true",
                        help="leave the board pictures out of the site (no KiCad needed unless "
                             "--rescore)")
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.core.errors import UserError
    from pcbdata.evaluator.leaderboard import make_leaderboard

    if (args.set_root or args.runs) and not args.rescore:
        raise UserError("--set and --runs go with --rescore (the folders to score again)")
    summary = make_leaderboard(args.results, args.out, rescore_files=args.rescore,
                               set_root=args.set_root, runs=args.runs, workers=args.workers,
                               pictures=not args.no_pictures, task_timeout=args.timeout)
    for note in summary["notes"]:
        print(f"leaderboard: {note}")
    print(f"done: {summary['files']} results files in {summary['tables']} tables, "
          f"{summary['pictures']} pictures: {args.out}/index.html, {args.out}/leaderboard.md")
    return 0

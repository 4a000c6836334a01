"""`pcbdata verify DIR [--release]`: re-check a built board set against its manifest and,
with --release, the manifest against the releases pinned in the package."""
from __future__ import annotations

VERB = "verify"
HELP = "check every board (and published shard) of a built set against its manifest"


def register(parser) -> None:
    parser.add_argument("dir", metavar="DIR", help="folder of a built board set")
    parser.add_argument("--release", action="store_true",
                        help="also compare the set (versions, parameters, splits, every board's "
                             "sha256) with the release manifests pinned in pcbdata; a subset "
                             "(fewer splits, or a --count build) passes if every board it holds "
                             "is the released one")
    parser.add_argument("--max-lines", type=int, default=50, metavar="N",
                        help="problems printed at most (default 50; all are counted)")
    parser.set_defaults(run=checked_run)


def checked_run(args) -> int:
    """`run` once the options are in range (a negative --max-lines would hide problems)."""
    from pcbdata.core.errors import UserError

    if args.max_lines < 0:
        raise UserError(f"--max-lines must be an integer >= 0, got {args.max_lines}")
    return run(args)


def run(args) -> int:
    from pcbdata.model.manifest import read_manifest
    from pcbdata.sets.verify import verify_release, verify_set

    problems = verify_set(args.dir)
    checks = verify_release(args.dir) if args.release else []
    for check in checks:
        problems += check.problems
    manifest = read_manifest(args.dir)
    boards = sum(len(s["boards"]) for c in manifest["configs"].values()
                 for s in c["splits"].values())
    for line in problems[: args.max_lines]:
        print(line)
    if len(problems) > args.max_lines:
        print(f"... and {len(problems) - args.max_lines} more")
    for check in checks:
        print(check.line())
    configs = ", ".join(sorted(manifest["configs"]))
    status = "OK" if not problems else f"{len(problems)} problem(s)"
    flag = " --release" if args.release else ""
    print(f"verify {args.dir}{flag}: {boards} boards in {configs}: {status}")
    return 0 if not problems else 1

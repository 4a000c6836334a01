"""Options shared by the synthetic `build` families (d1, d2)."""
from __future__ import annotations

import os

from pcbdata.cli import _checks as checks
from pcbdata.errors import UserError
from pcbdata.generators.base import SPLITS


# Board ids have five digits (`board_00000` .. `board_99999`) and sort in index order only
# while they do.
MAX_COUNT = 100_000


def add_common(parser) -> None:
    parser.add_argument("--out", required=True, metavar="DIR", help="folder of the board set")
    parser.add_argument("--splits", default="train,validation,test", metavar="LIST",
                        help="comma-separated splits among train, validation, test (default: all)")
    parser.add_argument("--workers", type=checks.workers,
                        default=min(os.cpu_count() or 1, checks.MAX_WORKERS),
                        metavar="N",
                        help="worker processes for generation and KiCad checks (default: all cores)")
    parser.add_argument("--seed", type=checks.seed, default=None,
                        help="base seed, 0 to 2**63 - 1 (default: the preset's seed)")
    parser.add_argument("--count", type=checks.integer(1, MAX_COUNT), default=None, metavar="N",
                        help="boards per split instead of the preset's split sizes "
                             "(board i is the same whatever the count)")
    parser.add_argument("--check-train", type=checks.non_negative, default=128, metavar="N",
                        help="train boards checked in KiCad, evenly spread (default: 128; "
                             "validation and test boards are always all checked)")
    parser.add_argument("--no-check", action="store_true",
                        help="skip the KiCad checks (the manifest records 0 checked boards)")


def parse_splits(text: str) -> list[str]:
    splits = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in splits if s not in SPLITS]
    if bad or not splits:
        raise UserError(f"--splits {text!r}: unknown split {bad[0] if bad else '(none)'!r}; "
                        f"choose from {', '.join(SPLITS)}")
    return [s for s in SPLITS if s in splits]


def split_sizes(args, preset_sizes: dict[str, int]) -> dict[str, int]:
    # argparse checked the ranges; this guards callers that build `args` themselves
    if args.count is not None and not 1 <= args.count <= MAX_COUNT:
        raise UserError(f"--count must be from 1 to {MAX_COUNT}, got {args.count}")
    if not 1 <= args.workers <= checks.MAX_WORKERS:
        raise UserError(f"--workers must be from 1 to {checks.MAX_WORKERS}, got {args.workers}")
    return {split: args.count or preset_sizes[split] for split in parse_splits(args.splits)}


def checked_indices(args, split: str, count: int) -> list[int]:
    from pcbdata.synthetic_build import check_sample

    if args.no_check:
        return []
    return check_sample(count, args.check_train if split == "train" else None)


def run_build(args, jobs, configs) -> int:
    import sys

    from pcbdata.errors import ValidationError
    from pcbdata.synthetic_build import build_synthetic

    checks.output_folder(args.out)  # last check, first write: a refused run leaves nothing
    names = ", ".join(sorted(configs))
    print(f"pcbdata build: {names} -> {args.out} ({args.workers} workers)", file=sys.stderr)
    try:
        summary = build_synthetic(args.out, jobs, configs, workers=args.workers)
    except ValidationError as exc:
        print(f"pcbdata: build failed: {exc}", file=sys.stderr)
        return 1
    from pcbdata.publish import publish_set

    publish_set(args.out, list(configs))
    print(f"done: {summary.line()}")
    return 0

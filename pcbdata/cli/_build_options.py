"""Options shared by the synthetic `build` families (d1, d2)."""
from __future__ import annotations

import os

from pcbdata.errors import UserError
from pcbdata.generators.base import SPLITS


def add_common(parser) -> None:
    parser.add_argument("--out", required=True, metavar="DIR", help="folder of the board set")
    parser.add_argument("--splits", default="train,validation,test", metavar="LIST",
                        help="comma-separated splits among train, validation, test (default: all)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1, metavar="N",
                        help="worker processes for generation and KiCad checks (default: all cores)")
    parser.add_argument("--seed", type=int, default=None,
                        help="base seed (default: the preset's seed)")
    parser.add_argument("--count", type=int, default=None, metavar="N",
                        help="boards per split instead of the preset's split sizes "
                             "(board i is the same whatever the count)")
    parser.add_argument("--check-train", type=int, default=128, metavar="N",
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
    if args.count is not None and args.count < 1:
        raise UserError(f"--count must be >= 1, got {args.count}")
    if args.workers < 1:
        raise UserError(f"--workers must be >= 1, got {args.workers}")
    return {split: args.count or preset_sizes[split] for split in parse_splits(args.splits)}


def checked_indices(args, split: str, count: int) -> list[int]:
    from pcbdata.synthetic_build import check_sample

    if args.no_check:
        return []
    return check_sample(count, args.check_train if split == "train" else None)


def run_build(args, jobs, configs) -> int:
    import sys

    from pcbdata.errors import ValidationError
    from pcbdata.publish import publish_set
    from pcbdata.synthetic_build import build_synthetic, locked_root

    names = ", ".join(sorted(configs))
    print(f"pcbdata build: {names} -> {args.out} ({args.workers} workers)", file=sys.stderr)
    with locked_root(args.out):  # a second build into the folder waits for this one
        try:
            summary = build_synthetic(args.out, jobs, configs, workers=args.workers)
        except ValidationError as exc:
            print(f"pcbdata: build failed: {exc}", file=sys.stderr)
            return 1
        publish_set(args.out, list(configs))
    print(f"done: {summary.line()}")
    return 0

"""Options shared by the synthetic `build` families (d1, d2)."""
from __future__ import annotations

import os

from pcbdata.build import MAX_COUNT
from pcbdata.cli import _checks as checks
from pcbdata.cli import _executor_options
from pcbdata.core.errors import UserError
from pcbdata.sets.configs import SYNTHETIC_SPLITS as SPLITS


def add_common(parser) -> None:
    parser.add_argument("--out", required=True, metavar="DIR", help="folder of the board set")
    parser.add_argument("--splits", default="train,validation,test", metavar="LIST",
                        help="comma-separated splits among train, validation, test (default: all)")
    parser.add_argument("--workers", type=checks.workers,
                        default=min(os.cpu_count() or 1, checks.MAX_WORKERS), metavar="N",
                        help="worker processes for generation and KiCad checks "
                             "(default: all cores)")
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
    _executor_options.add(parser)


def parse_splits(text: str) -> list[str]:
    splits = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in splits if s not in SPLITS]
    if bad or not splits:
        raise UserError(f"--splits {text!r}: unknown split {bad[0] if bad else '(none)'!r}; "
                        f"choose from {', '.join(SPLITS)}")
    return [s for s in SPLITS if s in splits]


def options(args):
    """The parsed common options as `pcbdata.build.SyntheticOptions`."""
    from pcbdata.build import SyntheticOptions

    return SyntheticOptions(splits=parse_splits(args.splits), seed=args.seed, count=args.count,
                            check_train=args.check_train, check=not args.no_check,
                            workers=args.workers, executor=_executor_options.executor(args))

"""`pcbdata eval`: score a submission of routed boards (or a set's reference boards)."""
from __future__ import annotations

import os

from pcbdata.cli import _checks as checks
from pcbdata.cli import _executor_options
from pcbdata.evaluator.metrics import CONVENTIONS

VERB = "eval"
HELP = "score routed boards against a built board set (CP, Pot., Rout., DRV, WL, Via, Time)"


def default_workers() -> int:
    # KiCad's DRC waits about 250 ms per board while using ~0.045 s of CPU for a D2 board: it
    # takes ~8 workers per core to keep the cores busy (measured: 8 -> 16 workers on 2 cores
    # took 640 rollouts from 24.7 s to 16.6 s; 24 workers gained nothing more).
    return max(1, min(32, 8 * (os.cpu_count() or 1)))


def register(parser) -> None:
    parser.add_argument("dir", metavar="DIR", help="a built board set (holds manifest.json)")
    parser.add_argument("--config", required=True, help="config name, e.g. d2, d1-g10, d3-a")
    parser.add_argument("--split", default="test", help="split name (default: test)")
    parser.add_argument("--runs", metavar="RUNS",
                        help="submission folder: RUNS/<board_id>/<rollout>.kicad_pcb "
                             "(+ optional <rollout>.json with time_s)")
    parser.add_argument("--reference", action="store_true",
                        help="score the set's reference boards (D3, D1 random-walk, D2R built "
                             "with --reference-agent) instead of a submission; boards without "
                             "one are counted, named and left out")
    parser.add_argument("--out", required=True, metavar="REPORT", help="report folder (resumable)")
    parser.add_argument("--k", type=checks.positive, default=5,
                        help="rollouts per board (default: 5)")
    parser.add_argument("--workers", type=checks.workers, default=default_workers(),
                        help="KiCad worker processes (default: 8 per core, at most 32: KiCad's "
                             "DRC spends most of a small board's time waiting, not computing)")
    parser.add_argument("--name", help="method name in the table (default: RUNS folder name)")
    parser.add_argument("--timeout", type=checks.seconds, default=300.0,
                        help="seconds allowed per board (default: 300)")
    parser.add_argument("--limit", type=checks.positive, metavar="N",
                        help="score only the first N boards of the split (board-id order)")
    parser.add_argument("--convention", choices=sorted(CONVENTIONS), default="spec",
                        help="scoring convention: 'spec' (SPEC section 4, the default) or "
                             "'d1-published' (the paper's D1 Pot. column: no WL or via term, "
                             "Phi(bare) = -U0; a clean complete D1 route scores 6.946); "
                             "recorded in the report")
    parser.add_argument("--lw", type=checks.weight, default=None,
                        help="potential weight per mm of WL (default 0.002; not with "
                             "--convention d1-published)")
    parser.add_argument("--lv", type=checks.weight, default=None,
                        help="potential weight per via (default 0.1; not with --convention "
                             "d1-published)")
    parser.add_argument("--no-cache", action="store_true",
                        help="score every rollout again, ignoring REPORT/scores.jsonl (the way to "
                             "trust a REPORT folder you did not write)")
    parser.add_argument("--allow-unverified", action="store_true",
                        help="score boards that do not match the set's manifest (refused "
                             "otherwise); the report and the table say so")
    _executor_options.add(parser)
    parser.set_defaults(run=run)


def weights_of(args):
    """The potential's weights: the convention's, with --lw / --lv over the default one."""
    from dataclasses import replace

    from pcbdata.core.errors import UserError

    base = CONVENTIONS[args.convention]
    given = {k: v for k, v in (("lw", args.lw), ("lv", args.lv)) if v is not None}
    if given and args.convention != "spec":
        raise UserError(f"--convention {args.convention} fixes the weights; drop "
                        f"{', '.join('--' + k for k in given)}")
    return replace(base, **given)


def run(args) -> int:
    from pcbdata.evaluator.runs import evaluate_set

    result = evaluate_set(args.dir, args.config, args.split, args.out, runs=args.runs,
                          k=args.k, reference=args.reference, workers=args.workers,
                          weights=weights_of(args), name=args.name,
                          task_timeout=args.timeout, limit=args.limit,
                          executor=_executor_options.executor(args),
                          use_cache=not args.no_cache, allow_unverified=args.allow_unverified)
    print(result["table"], end="")
    return 0

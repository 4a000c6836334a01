"""`pcbdata rollout`: run an agent in the routing environment over a board set."""
from __future__ import annotations

import os
import sys

from pcbdata.cli import _executor_options

VERB = "rollout"
HELP = "route a board set with an agent (scripted, scripted-shove, d1, random, module:Class)"


def register(parser) -> None:
    parser.add_argument("dir", metavar="SET", help="a built board set")
    parser.add_argument("--config", required=True,
                        help="any config the set holds, e.g. d2, d1-g10-random-walk, "
                             "d2-hard-custom-<hash>, d3-a (read from its manifest)")
    parser.add_argument("--split", default="test", help="split name (default: test)")
    parser.add_argument("--agent", default="scripted",
                        help="scripted (default), scripted-shove (push_n_shove when walkaround "
                             "fails), d1 (D1 boards: lattice plan with rip-up and reroute), "
                             "random, policy (the shipped learned router; policy:CHECKPOINT for "
                             "another, docs/learn.md), or module:Class with act(obs, info)")
    parser.add_argument("--rollouts", type=int, default=1, help="rollouts per board (seeds 0..)")
    parser.add_argument("--out", required=True, metavar="RUNS",
                        help="RUNS/<board_id>/<rollout>.kicad_pcb + .json (pcbdata eval reads it)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="parallel environments, each with its KiCad worker (default: cores; "
                             "--executor ray uses every CPU of the cluster)")
    parser.add_argument("--limit", type=int, help="only the first N boards")
    parser.add_argument("--max-steps", type=int, default=200, help="step limit (default: 200)")
    parser.add_argument("--drc", choices=("step", "terminal"), default="step",
                        help="KiCad DRC after every copper change (default) or at the end only")
    _executor_options.add(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.agents.rollout import run_rollouts
    from pcbdata.core.errors import UserError

    if args.rollouts < 1 or args.workers < 1:
        raise UserError("--rollouts and --workers must be at least 1")
    summary = run_rollouts(args.dir, args.config, args.split, args.agent, args.rollouts,
                           args.out, args.workers, args.limit,
                           {"max_steps": args.max_steps, "drc": args.drc},
                           executor=_executor_options.executor(args))
    mean = summary["mean_reward"]
    print(f"done: {summary['run']} rollouts run, {summary['skipped']} already done, "
          f"{summary['terminated']} fully connected, {summary['engine_failures']} engine "
          f"failures, mean reward {mean:.3f}" if mean is not None else
          f"done: nothing to run ({summary['skipped']} already done)", end="")
    print(f", {summary['seconds']:.1f} s")
    if summary["failed"]:
        print(f"pcbdata: KiCad failed: {summary['failed']} rollouts failed (time limit or crash; "
              f"see above); run again to retry them", file=sys.stderr)
        return 3
    return 0

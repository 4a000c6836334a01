"""`pcbdata route`: route a board set with a Specctra router (baseline submissions)."""
from __future__ import annotations

import os

from pcbdata.cli import _checks as checks

VERB = "route"
HELP = ("route a board set with a baseline router (freeroute via Specctra DSN/SES, kicad-tools, "
        "or pcbdata's negotiated planner)")


def register(parser) -> None:
    parser.add_argument("dir", metavar="DIR", help="a built board set")
    parser.add_argument("--config", required=True, help="config name, e.g. d2, d3-a")
    parser.add_argument("--split", default="test", help="split name (default: test)")
    parser.add_argument("--out", required=True, metavar="RUNS",
                        help="output folder: RUNS/<board_id>/<rollout>.kicad_pcb (+ .json)")
    parser.add_argument("--router", default="freeroute",
                        choices=("freeroute", "kicad-tools", "negotiated"),
                        help="freeroute (Specctra round trip, default) or kicad-tools (`kct "
                             "route`, optional extra), both run as separate processes; or "
                             "negotiated: pcbdata's whole-board planner with rip-up and "
                             "reroute, its copper laid and judged by KiCad (the same as "
                             "`pcbdata rollout --agent negotiated --drc terminal`)")
    parser.add_argument("--router-cmd", metavar="CMD",
                        help="any DSN->SES command, with {dsn} and {ses} placeholders, e.g. "
                             "'java -jar freerouting.jar -de {dsn} -do {ses}'")
    parser.add_argument("--rollouts", type=checks.positive, default=1,
                        help="rollouts per board; freeroute cycles through engine variants, "
                             "kicad-tools through seeds")
    parser.add_argument("--workers", type=checks.workers,
                        default=min(os.cpu_count() or 1, checks.MAX_WORKERS),
                        help="parallel boards (default: CPU count)")
    parser.add_argument("--timeout", type=checks.seconds, default=120.0,
                        help="seconds allowed to the router per board (default: 120)")
    parser.add_argument("--limit", type=checks.positive, metavar="N",
                        help="route only the first N boards")
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.baselines.route import route_set
    from pcbdata.core.errors import UserError

    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise UserError(f"--out {args.out}: exists and is not a folder (RUNS is a folder)")
    if args.router == "negotiated":
        return _negotiated(args)
    counts = route_set(args.dir, args.config, args.split, args.out, router=args.router,
                       router_cmd=args.router_cmd, rollouts=args.rollouts, workers=args.workers,
                       router_timeout=args.timeout, limit=args.limit)
    print(f"routed {counts['routed']}, failed {counts['failed']}, "
          f"skipped {counts['skipped']} (already routed)")
    return 0


def _negotiated(args) -> int:
    """The negotiated planner on whole boards: its plan laid in the environment (KiCad holds
    and judges the copper), DRC at the end, the rollouts written as `pcbdata eval` reads them."""
    from pcbdata.core.errors import UserError
    from pcbdata.runners.rollout import run_rollouts

    if args.router_cmd:
        raise UserError("--router-cmd is for Specctra routers, not --router negotiated")
    summary = run_rollouts(args.dir, args.config, args.split, "negotiated", args.rollouts,
                           args.out, args.workers, limit=args.limit,
                           env_options={"drc": "terminal"})
    print(f"routed {summary['run']}, failed {summary['failed']}, "
          f"skipped {summary['skipped']} (already routed)")
    return 3 if summary["failed"] else 0

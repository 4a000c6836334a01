"""`pcbdata build d2r`: realistic synthetic boards, one level per D3 tier (SPEC 2b)."""
from __future__ import annotations

from pcbdata.cli import _build_options as common
from pcbdata.cli import _checks as checks
from pcbdata.runners.reference import AGENTS, DEFAULT_AGENT, DEFAULT_ROLLOUTS, MAX_ROLLOUTS

FAMILY = "d2r"
HELP = ("D2R realistic boards (multi-pad parts, net classes, shaped outlines), one level per "
        "D3 tier")


def register(parser) -> None:
    parser.add_argument("--level", default="b", metavar="NAME",
                        help="level from pcbdata/resources/presets/d2r_levels.toml: a, b or c "
                             "(the D3 tier it is calibrated to; default: b); `pcbdata levels` "
                             "lists them")
    parser.add_argument("--level-version", default=None, metavar="VERSION",
                        help="an earlier version of the level, kept in the package (e.g. "
                             "4.0.0 of level b): its boards byte for byte, which `pcbdata "
                             "verify --release` compares with that version's pinned release "
                             "(default: the current version)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        dest="overrides",
                        help="override one parameter (repeatable), TOML values: "
                             "--set components_median=25 --set power_rails=[1,2,3] "
                             "--set 'outline_mix={rect=0.5,rounded=0.5}'")
    common.add_common(parser)
    _add_reference_options(parser)
    parser.set_defaults(run=run)


def _add_reference_options(parser) -> None:
    group = parser.add_argument_group(
        "reference routing (docs/realistic.md): boards the agent does not complete stay in "
        "the set, without a reference")
    group.add_argument("--reference-agent", nargs="?", const=DEFAULT_AGENT, choices=AGENTS,
                       metavar="NAME",
                       help="route each board of the reference splits with a bundled agent "
                            "in the routing environment (--workers boards at a time) and keep "
                            "its first clean rollout as reference.kicad_pcb: "
                            f"{DEFAULT_AGENT} (the default when NAME is left out) or "
                            f"{', '.join(a for a in AGENTS if a != DEFAULT_AGENT)}")
    group.add_argument("--reference-rollouts", type=checks.integer(1, MAX_ROLLOUTS),
                       metavar="K",
                       help=f"rollouts per board, seeds 0..K-1, stopping at the first clean "
                            f"one (default: {DEFAULT_ROLLOUTS})")
    group.add_argument("--reference-splits", metavar="LIST",
                       help="comma-separated splits to route, among those built (default: "
                            "validation,test; train only when named: 10,000 boards take "
                            "hours)")


def run(args) -> int:
    from pcbdata.build import build_level
    from pcbdata.sets.presets import parse_overrides

    overrides = parse_overrides(args.overrides)
    options = common.options(args)
    options.reference = reference_plan(args)
    summary = build_level(args.out, "d2r", args.level, overrides, options,
                          version=args.level_version)
    print(f"done: {summary.line()}")
    return 0


def reference_plan(args):
    """The `ReferencePlan` the options ask for, or None (no --reference-agent)."""
    from pcbdata.core.errors import UserError
    from pcbdata.runners.reference import plan

    if args.reference_agent is None:
        given = [flag for flag, value in (("--reference-rollouts", args.reference_rollouts),
                                          ("--reference-splits", args.reference_splits))
                 if value is not None]
        if given:
            raise UserError(f"{given[0]} needs --reference-agent")
        return None
    splits = None if args.reference_splits is None else \
        [s.strip() for s in args.reference_splits.split(",") if s.strip()]
    rollouts = DEFAULT_ROLLOUTS if args.reference_rollouts is None else args.reference_rollouts
    return plan(args.reference_agent, rollouts, splits)

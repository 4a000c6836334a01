"""`pcbdata build d2r`: realistic synthetic boards, one level per D3 tier (SPEC 2b)."""
from __future__ import annotations

from pcbdata.cli import _build_options as common

FAMILY = "d2r"
HELP = ("D2R realistic boards (multi-pad parts, net classes, shaped outlines), one level per "
        "D3 tier")


def register(parser) -> None:
    parser.add_argument("--level", default="b", metavar="NAME",
                        help="level from pcbdata/resources/presets/d2r_levels.toml: a, b or c "
                             "(the D3 tier it is calibrated to; default: b); `pcbdata levels` "
                             "lists them")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        dest="overrides",
                        help="override one parameter (repeatable), TOML values: "
                             "--set components_median=25 --set power_rails=[1,2,3] "
                             "--set 'outline_mix={rect=0.5,rounded=0.5}'")
    common.add_common(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.builders import build_d2r
    from pcbdata.spec.presets import parse_overrides

    overrides = parse_overrides(args.overrides)
    summary = build_d2r(args.out, args.level, overrides, common.options(args))
    print(f"done: {summary.line()}")
    return 0

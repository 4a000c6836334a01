"""`pcbdata build d2`: synthetic gridless two-layer boards at a difficulty level (SPEC 2)."""
from __future__ import annotations

from pcbdata.cli import _build_options as common

FAMILY = "d2"
HELP = "D2 gridless two-layer boards with multi-pin nets, at the benchmark's or another level"


def register(parser) -> None:
    parser.add_argument("--level", default="default", metavar="NAME",
                        help="difficulty level from pcbdata/resources/presets/d2_levels.toml "
                             "(default: the benchmark's); `pcbdata levels` lists them")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        dest="overrides",
                        help="override one parameter (repeatable), TOML values: "
                             "--set min_pad_spacing_mm=4.2 --set net_counts=[6,7] "
                             "--set 'pads_per_net={2=0.5,3=0.5}'")
    common.add_common(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.build import build_level
    from pcbdata.sets.presets import parse_overrides

    overrides = parse_overrides(args.overrides)
    summary = build_level(args.out, "d2", args.level, overrides, common.options(args))
    print(f"done: {summary.line()}")
    return 0

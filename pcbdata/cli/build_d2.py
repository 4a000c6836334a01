"""`pcbdata build d2`: synthetic gridless two-layer boards at a difficulty level (SPEC section 2)."""
from __future__ import annotations

from pcbdata.cli import _build_options as common

FAMILY = "d2"
HELP = "D2 gridless two-layer boards with multi-pin nets, at the benchmark's or another level"


def register(parser) -> None:
    parser.add_argument("--level", default="default", metavar="NAME",
                        help="difficulty level from pcbdata/resources/presets/d2_levels.toml (default: the "
                             "benchmark's); `pcbdata levels` lists them")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        dest="overrides",
                        help="override one parameter (repeatable), TOML values: "
                             "--set min_pad_spacing_mm=4.2 --set net_counts=[6,7] "
                             "--set 'pads_per_net={2=0.5,3=0.5}'")
    common.add_common(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.generators import D2Generator
    from pcbdata.presets import d2_level, parse_overrides
    from pcbdata.synthetic_build import ConfigInfo, SplitJob

    overrides = parse_overrides(args.overrides)
    level = d2_level(args.level, overrides)
    sizes = common.split_sizes(args, level.splits)
    seed = level.seed if args.seed is None else args.seed
    generator = D2Generator(level.params)
    config = level.config_name
    configs = {config: ConfigInfo(
        family="d2", set_version=level.version, seed=seed, parameters=level.params.as_dict(),
        extra={"level": level.name, "level_description": level.description,
               "overrides": level.overrides})}
    jobs = [SplitJob(config, split, count, generator, common.checked_indices(args, split, count))
            for split, count in sizes.items()]
    return common.run_build(args, jobs, configs)

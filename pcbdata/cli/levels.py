"""`pcbdata levels`: the D2 difficulty levels of this version."""
from __future__ import annotations

VERB = "levels"
HELP = "list the D2 difficulty levels with their parameters"


def register(parser) -> None:
    parser.add_argument("--json", action="store_true", help="full parameters as JSON")
    parser.set_defaults(run=run)


def run(args) -> int:
    import json

    from pcbdata.presets import d2_level, d2_levels

    levels = sorted(d2_levels(), key=lambda name: d2_levels()[name]["rank"])
    if args.json:
        print(json.dumps({name: d2_level(name).params.as_dict() for name in levels}, indent=1))
        return 0
    for name in levels:
        level = d2_level(name)
        print(f"{level.rank}  {name:<10} {level.config_name:<11} {level.description}")
    return 0

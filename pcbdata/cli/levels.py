"""`pcbdata levels`: the levels of every family with levels (D2's difficulty levels, D2R's
realistic levels, and any registered family's) of this version."""
from __future__ import annotations

VERB = "levels"
HELP = "list the D2 difficulty levels and the D2R realistic levels with their parameters"


def _level_families() -> list[str]:
    from pcbdata.generators.families import families

    return [record.name for record in families() if record.has_levels]


def register(parser) -> None:
    parser.add_argument("--family", choices=_level_families(), default=None,
                        help="only this family's levels (with --json: default d2)")
    parser.add_argument("--json", action="store_true",
                        help="full parameters as JSON, by level name, of one family")
    parser.set_defaults(run=run)


def run(args) -> int:
    import json

    from pcbdata.sets.configs import registry

    families = [args.family] if args.family else _level_families()
    if args.json:
        families = [args.family or "d2"]
    specs = [spec for spec in registry().values() if spec.family in families]  # rank order
    if args.json:
        print(json.dumps({spec.level: spec.parameters for spec in specs}, indent=1))
        return 0
    for spec in specs:
        print(f"{spec.rank}  {spec.level:<10} {spec.name:<11} {spec.description}")
    return 0

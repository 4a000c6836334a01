"""`pcbdata levels`: the D2 difficulty levels and the realistic (D2R) levels of this version."""
from __future__ import annotations

VERB = "levels"
HELP = "list the D2 difficulty levels and the D2R realistic levels with their parameters"


def register(parser) -> None:
    parser.add_argument("--json", action="store_true", help="full parameters as JSON")
    parser.set_defaults(run=run)


def run(args) -> int:
    import json

    from pcbdata.spec.configs import registry

    specs = registry().values()
    levels = [spec for spec in specs if spec.family == "d2"]  # in rank order
    realistic = [spec for spec in specs if spec.family == "d2r"]
    if args.json:
        table = {spec.level: spec.parameters for spec in levels}
        table.update({spec.name: spec.parameters for spec in realistic})
        print(json.dumps(table, indent=1))
        return 0
    for spec in levels:
        print(f"{spec.rank}  {spec.level:<10} {spec.name:<11} {spec.description}")
    for spec in realistic:
        print(f"{spec.rank}  {spec.level:<10} {spec.name:<11} {spec.description}")
    return 0

"""`pcbdata levels`: the D2 difficulty levels of this version."""
from __future__ import annotations

VERB = "levels"
HELP = "list the D2 difficulty levels with their parameters"


def register(parser) -> None:
    parser.add_argument("--json", action="store_true", help="full parameters as JSON")
    parser.set_defaults(run=run)


def run(args) -> int:
    import json

    from pcbdata.spec.configs import registry

    levels = [spec for spec in registry().values() if spec.family == "d2"]  # in rank order
    if args.json:
        print(json.dumps({spec.level: spec.parameters for spec in levels}, indent=1))
        return 0
    for spec in levels:
        print(f"{spec.rank}  {spec.level:<10} {spec.name:<11} {spec.description}")
    return 0

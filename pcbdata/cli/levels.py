"""`pcbdata levels`: the D2 difficulty levels and the realistic (D2R) levels of this version."""
from __future__ import annotations

VERB = "levels"
HELP = "list the D2 difficulty levels and the D2R realistic levels with their parameters"


def register(parser) -> None:
    parser.add_argument("--family", choices=("d2", "d2r"), default=None,
                        help="only this family's levels (with --json: default d2)")
    parser.add_argument("--json", action="store_true",
                        help="full parameters as JSON, by level name, of one family")
    parser.set_defaults(run=run)


def run(args) -> int:
    import json

    from pcbdata.spec.configs import registry

    families = [args.family] if args.family else ["d2", "d2r"]
    if args.json:
        families = [args.family or "d2"]
    specs = [spec for spec in registry().values() if spec.family in families]  # rank order
    if args.json:
        print(json.dumps({spec.level: spec.parameters for spec in specs}, indent=1))
        return 0
    for spec in specs:
        print(f"{spec.rank}  {spec.level:<10} {spec.name:<11} {spec.description}")
    return 0

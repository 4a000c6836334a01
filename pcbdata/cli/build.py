"""`pcbdata build <family>`: one module per family (build_d1, build_d2, build_d2r, build_d3)."""
from __future__ import annotations

VERB = "build"
HELP = "build a board set (d1, d2, d2r or d3) into a folder"


def register(parser) -> None:
    from pcbdata.cli import verb_modules

    families = parser.add_subparsers(dest="family", metavar="FAMILY", required=True)
    for module in verb_modules(prefix="build_"):
        sub = families.add_parser(module.FAMILY, help=module.HELP, description=module.HELP)
        module.register(sub)

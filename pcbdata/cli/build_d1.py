"""`pcbdata build d1`: synthetic grid boards (SPEC section 1)."""
from __future__ import annotations

from pcbdata.cli import _build_options as common
from pcbdata.core.errors import UserError

FAMILY = "d1"
HELP = "D1 grid boards: 5 two-pin nets, one routing layer, grid sizes 10..500"


def register(parser) -> None:
    parser.add_argument("--grid", default="all", metavar="G",
                        help="grid size(s): 10, 50, 100, 200, 500, any integer >= 4, a comma "
                             "list, or 'all' (default)")
    parser.add_argument("--placement", default=None, choices=("uniform", "random-walk"),
                        help="pad placement (default: the preset's, uniform); random-walk boards "
                             "also get reference.kicad_pcb, a DRC-clean routing")
    common.add_common(parser)
    parser.set_defaults(run=run)


def parse_grids(text: str, preset_grids) -> list[int]:
    if text.strip() == "all":
        return list(preset_grids)
    grids = []
    for part in text.split(","):
        try:
            grid = int(part)
        except ValueError:
            raise UserError(f"--grid {text!r}: {part.strip()!r} is not an integer grid size "
                            f"or 'all'") from None
        if grid in grids:
            raise UserError(f"--grid {text!r}: grid {grid} is listed twice")
        grids.append(grid)
    return grids


def run(args) -> int:
    from pcbdata.build import build_d1
    from pcbdata.sets.presets import d1_preset

    summary = build_d1(args.out, parse_grids(args.grid, d1_preset().grid_sizes), args.placement,
                       common.options(args))
    print(f"done: {summary.line()}")
    return 0

"""The real board of each D3 tier that a D2R level's card picture shows beside a synthetic one.

A D2R set is built without D3 at hand, so the real side ships with the package: one picture per
tier (`pcbdata/resources/real_boards/d3-<tier>.png`, the bare board as `pcbdata render` draws
it) and its attribution (`real_boards.toml`: board id, author, licence, source repository and
the sha256 of the D3 board file it was drawn from). Pictures of PCBench boards, not the boards.

Maintainers redraw them from a D3 build (KiCad reads the boards):

    python -m pcbdata.publish.real_boards D3_DIR [--out DIR]
"""
from __future__ import annotations

import argparse
import hashlib
import sys
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pcbdata.board_render import Picture, draw_picture, read_boards
from pcbdata.core.drawing import png_bytes, png_image
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import write_atomic
from pcbdata.core.tree import BOARD_FILE, board_dir
from pcbdata.kicad import KicadPool
from pcbdata.publish.layout import PICTURES_DIR
from pcbdata.resources import resource_path
from pcbdata.sets.configs import D3_TIERS
from pcbdata.sets.presets import levels

_FOLDER = "real_boards"
_INDEX = "real_boards.toml"
_D3_SPLIT = "full"


@dataclass(frozen=True)
class RealBoard:
    tier: str
    board_id: str
    author: str
    licence: str
    source_repository: str
    board_sha256: str  # of D3's `full/<board_id>/board.kicad_pcb`, the file drawn

    @property
    def picture_name(self) -> str:
        return f"d3-{self.tier.lower()}.png"

    def caption(self) -> str:
        return (f"`{self.board_id}` of D3-{self.tier}, by {self.author} "
                f"({self.source_repository}, {self.licence}; from PCBench, drawn by pcbdata)")


def real_boards() -> dict[str, RealBoard]:
    """The shipped real board per tier ("A", "B", "C")."""
    data = tomllib.loads(resource_path(_FOLDER, _INDEX).read_text(encoding="utf-8"))
    return {tier: RealBoard(tier=tier, **entry) for tier, entry in data["tiers"].items()}


def tier_real_board(cfg: dict) -> RealBoard | None:
    """The real board to show beside a manifest config's boards: a D2R level's tier's, else
    None (also for a level of no tier)."""
    if cfg.get("family") != "d2r":
        return None
    tier = levels("d2r").get(cfg.get("level") or "", {}).get("tier")
    return real_boards().get(tier) if tier else None


def beside_picture(config: str, board: RealBoard) -> str:
    """The set-relative path of the card picture of `config`'s board beside `board`."""
    return f"{PICTURES_DIR}/{config}/beside-d3-{board.tier.lower()}.svg"


def real_picture(board: RealBoard) -> np.ndarray:
    """The shipped picture of `board` (RGB array, its title bar included)."""
    return png_image(resource_path(_FOLDER, board.picture_name).read_bytes())


def draw_real_boards(d3_root: Path, out: Path, pool: KicadPool,
                     tiers: Sequence[str] = ("A", "B", "C")) -> list[Path]:
    """Redraws the tiers' pictures from a D3 build into `out`; the board files must be the
    ones `real_boards.toml` names (same sha256)."""
    boards = {tier: real_boards()[tier] for tier in tiers}
    paths = {tier: board_dir(d3_root, D3_TIERS[tier], _D3_SPLIT, b.board_id) / BOARD_FILE
             for tier, b in boards.items()}
    for tier, path in paths.items():
        if not path.is_file():
            raise UserError(f"{path}: missing (D3-{tier}'s board {boards[tier].board_id})")
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        if digest != boards[tier].board_sha256:
            raise UserError(f"{path}: sha256 {digest}, real_boards.toml names "
                            f"{boards[tier].board_sha256}: another D3 build")
    records = read_boards(sorted(paths.values()), pool)
    pictures = {}
    for tier, path in paths.items():  # all drawn before any is written: none or every one
        board = boards[tier]
        drawn = draw_picture(Picture(board.board_id, [(f"D3-{tier} {board.board_id}", path)]),
                             records)
        if isinstance(drawn, str):
            raise UserError(f"{path}: cannot be drawn ({drawn})")
        pictures[out / board.picture_name] = png_bytes(drawn)
    for target, data in pictures.items():
        write_atomic(target, data)
    return list(pictures)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("d3", type=Path, help="a D3 build (pcbdata build d3)")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the pictures (default: the package's own)")
    args = parser.parse_args(argv)
    out = args.out or Path(str(resource_path(_FOLDER)))
    try:
        with KicadPool(workers=1, task_timeout=300) as pool:
            for path in draw_real_boards(args.d3, out, pool):
                print(f"wrote {path}")
    except UserError as error:
        print(f"real_boards: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The generator protocol: what every board generator (D1, D2, ...) provides.

The build pipeline (`pcbdata.build.synthetic`), the golden tests and the routing environment
see generators through `Generator` only; family specifics stay in the family's module. A
generator that also exports whole splits as arrays (D1: the Connector arrays) implements
`SplitArrays` as well. `Family` is what a family tells the rest of pcbdata about itself (its
configs, seed streams, environment sizes and card text); `pcbdata.generators.families` keeps
the table.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.abc import Traversable
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from pcbdata.core.tree import synthetic_board_id
from pcbdata.model.board import Board, nm_to_mm

# Physical limits of generated boards, checked with the parameters (before anything is
# written). KiCad stores coordinates as signed 32-bit nanometres, so nothing can lie beyond
# +-2147.48 mm; boards and every length are kept to 1 m, well inside that range (and below the
# largest page KiCad offers, 1219 mm). Copper features, clearances and holes are at least
# 10 micrometres: finer than any PCB process, and far above the 1 nm resolution of the files.
MAX_LENGTH_MM = 1000.0
MIN_FEATURE_MM = 0.01
# KiCad 9 board-setup minimums that the written projects keep (the DRC of a generated board
# reports them; measured): annular ring of a pad or via, and hole to other-net copper.
KICAD_MIN_ANNULAR_MM = 0.1
KICAD_HOLE_CLEARANCE_MM = 0.25


def board_id(index: int) -> str:
    return synthetic_board_id(index)


@dataclass
class Instance:
    """One generated task: the bare board, and for some generators a reference routing."""

    board_id: str
    board: Board
    reference: Board | None = None

    def facts(self, routing_layers: int) -> dict:
        """The per-board facts of the manifest (`pcbdata.model.manifest.BOARD_FACTS`)."""
        board = self.board
        return {
            "n_nets": len(board.net_names),
            "n_pads": board.n_pads,
            "n_components": board.n_components,
            "n_layers": board.copper_layers,
            "routing_layers": min(routing_layers, board.copper_layers),
            "width_mm": nm_to_mm(board.width),
            "height_mm": nm_to_mm(board.height),
        }


@runtime_checkable
class Generator(Protocol):
    """A board generator: (seed, split, index) in, one `Instance` out.

    Guarantee, stated by every implementation (which may add its own): the same parameters,
    seed, split and index give the same instance, byte for byte once written (draws from
    `pcbdata.core.rng.Stream`, one stream per board); the board loads in KiCad 9.0.8 and its DRC
    reports nothing but the unconnected items routing resolves
    (`instance.board.missing_connections`); a reference routing, when there is one, is
    DRC-clean and fully connected. Parameters a generator cannot realise are rejected when it is
    made (`UserError`); a board that still cannot be made raises `GenerationError`.
    Generators are picklable: builds run them in worker processes.
    """

    family: str          # the family's name ("d1", "d2", "d2r": `Family.name`)
    routing_layers: int  # copper layers routing may use (a fact of every board)

    def generate(self, seed: int, split: str, index: int) -> Instance: ...


@runtime_checkable
class SplitArrays(Protocol):
    """A generator that also exports each split as arrays (`<config>/<split>.npz`)."""

    def array_row(self, instance: Instance) -> Any:
        """The row of one board (plain data, sent back from worker processes)."""

    def split_arrays(self, board_ids: list[str], rows: list) -> bytes:
        """The `.npz` bytes of a split from its boards' rows, in board order."""


@dataclass(frozen=True)
class Family:
    """One generator family, as the rest of pcbdata sees it (`pcbdata.generators.families`).

    `name` starts every config name of the family (`d2r-a`); `seed_key` is the family's key of
    the random streams (`pcbdata.core.rng.Stream`: disjoint per family); `params` is its typed
    parameter set (`from_dict(values, where)`, `as_dict()`); `make_generator(parameters,
    manifest, where)` makes its generator from the parameters and the extra manifest fields a
    config records; `capacities` are the routing environment's observation sizes for its
    boards; `title` and `text` head its part of a dataset card. A family with levels keeps them
    in `levels_file` (a TOML file: `version`, `seed`, `[splits]`, `[levels.<name>]` tables of
    parameters plus `level_meta` fields); `default_level` is the level the bare family name
    means (`d2` is D2's `default`). `seed_coupling` and `seed_scheme` are the manifest's texts;
    `rank` orders families in listings (smaller first)."""

    name: str
    seed_key: int
    params: type
    make_generator: Callable[[dict, dict, str], Generator]
    capacities: Mapping[str, int]
    title: str
    text: str
    seed_coupling: str
    seed_scheme: str
    rank: int
    levels_file: Traversable | Path | None = None
    default_level: str | None = None
    level_meta: tuple[str, ...] = ("rank", "description", "version")

    @property
    def has_levels(self) -> bool:
        return self.levels_file is not None

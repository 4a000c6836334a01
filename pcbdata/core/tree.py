"""The built tree of a board set: the one module that owns its layout and file names.

    DIR/manifest.json                                   written last: the set is complete
    DIR/<config>/<split>/<board_id>/board.kicad_pcb     the task (bare board)
    DIR/<config>/<split>/<board_id>/board.kicad_pro     its project: design rules, severities
    DIR/<config>/<split>/<board_id>/board.kicad_dru     custom rules (D1: the one-layer rule)
    DIR/<config>/<split>/<board_id>/reference.kicad_pcb a routed solution (D1 random-walk, D3,
                                                        D2R built with --reference-agent)
    DIR/<config>/<split>.npz                            split arrays (D1: the Connector arrays)
    DIR/.pcbdata/checks.jsonl                           synthetic builds: KiCad checks passed
    DIR/.pcbdata/references.jsonl                       synthetic builds: reference routings found
    DIR/.d3-state/                                      D3 builds: per-board engine results
    DIR/characteristics.csv, curation_report.*, attribution.*, LICENSE-PCBench   D3 tables

Board ids: `board_NNNNN` (synthetic, by index), `NNNN_<name>` (D3, by characteristics row).
The published parts (card, shards, pictures) are `pcbdata.publish.layout`'s.

A leaf module (stdlib only): every layer, the KiCad layer included, may import it.
"""
from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

MANIFEST_NAME = "manifest.json"
BOARD_FILE = "board.kicad_pcb"
PROJECT_FILE = "board.kicad_pro"
RULES_FILE = "board.kicad_dru"
REFERENCE_FILE = "reference.kicad_pcb"
#: The files of an instance (the task): board, project, and custom rules where the family has them.
INSTANCE_FILES = (BOARD_FILE, PROJECT_FILE, RULES_FILE)

SYNTHETIC_STATE_DIR = ".pcbdata"
CHECK_LOG = "checks.jsonl"
REFERENCE_LOG = "references.jsonl"
D3_STATE_DIR = ".d3-state"

CHARACTERISTICS_CSV = "characteristics.csv"
CURATION_REPORT_CSV = "curation_report.csv"
CURATION_REPORT_JSON = "curation_report.json"
ATTRIBUTION_CSV = "attribution.csv"
ATTRIBUTION_JSON = "attribution.json"
PCBENCH_LICENCE = "LICENSE-PCBench"
#: The tables a D3 build writes next to the boards.
D3_TABLES = (ATTRIBUTION_CSV, ATTRIBUTION_JSON, PCBENCH_LICENCE, CHARACTERISTICS_CSV,
             CURATION_REPORT_CSV, CURATION_REPORT_JSON)


def synthetic_board_id(index: int) -> str:
    return f"board_{index:05d}"


def d3_board_id(row: int, name: str) -> str:
    return f"{row:04d}_{name}"


def manifest_path(root: str | os.PathLike) -> Path:
    return Path(root) / MANIFEST_NAME


def split_dir(root: str | os.PathLike, config: str, split: str) -> Path:
    return Path(root) / config / split


def board_dir(root: str | os.PathLike, config: str, split: str, board_id: str) -> Path:
    return Path(root) / config / split / board_id


def board_relpath(config: str, split: str, board_id: str, name: str | None = None) -> str:
    """`config/split/board_id[/name]`: how messages and logs name a board (or one of its files)."""
    rel = f"{config}/{split}/{board_id}"
    return f"{rel}/{name}" if name else rel


def list_instances(root: str | os.PathLike, config: str, split: str) -> list[tuple[str, Path]]:
    """(board_id, instance folder) of a built set's config and split, in board-id order; a
    missing config/split or an empty one is a `UserError` naming the configs the set holds."""
    from pcbdata.core.errors import UserError

    root = Path(root)
    base = split_dir(root, config, split)
    if not base.is_dir():
        held = held_splits(root)
        known = (f"{config} has splits: {', '.join(held[config]) or 'none'}" if config in held
                 else f"configs: {', '.join(sorted(held)) or 'none'}")
        raise UserError(f"{base}: no such config/split in {root} ({known})")
    boards = sorted((p.name, p) for p in base.iterdir() if (p / BOARD_FILE).is_file())
    if not boards:
        raise UserError(f"{base}: holds no boards")
    return boards


def held_splits(root: str | os.PathLike) -> dict[str, list[str]]:
    """{config: its splits} of a built set, as its manifest records them; a set without a
    readable manifest (boards written by hand): the folders that hold boards."""
    root = Path(root)
    try:
        configs = json.loads(manifest_path(root).read_text(encoding="utf-8"))["configs"]
        return {name: sorted(entry["splits"]) for name, entry in configs.items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        held: dict[str, set[str]] = {}
        for board in root.glob(f"*/*/*/{BOARD_FILE}"):
            held.setdefault(board.parts[-4], set()).add(board.parts[-3])
        return {name: sorted(splits) for name, splits in held.items()}


def arrays_name(split: str) -> str:
    return f"{split}.npz"


def arrays_path(root: str | os.PathLike, config: str, split: str) -> Path:
    return Path(root) / config / arrays_name(split)


def check_log_path(root: str | os.PathLike) -> Path:
    return Path(root) / SYNTHETIC_STATE_DIR / CHECK_LOG


def reference_log_path(root: str | os.PathLike) -> Path:
    return Path(root) / SYNTHETIC_STATE_DIR / REFERENCE_LOG


def folder_holds(folder: Path, files: Mapping[str, bytes], may_hold: tuple[str, ...] = ()) -> bool:
    """Whether `folder` holds exactly `files` (names and bytes), besides any of `may_hold`
    (files a later stage adds, e.g. a router-found reference): a finished board is kept."""
    try:
        listed = [name for name in os.listdir(folder) if name in files or name not in may_hold]
        if sorted(listed) != sorted(files):
            return False
        return all((folder / name).read_bytes() == data for name, data in files.items())
    except (FileNotFoundError, NotADirectoryError):
        return False

"""Scanning a PCBench checkout: one `SourceBoard` per board folder, with the facts that need no
KiCad (hashes, `final.json` counts, metadata) and the fate it already has (missing input, an
unreadable `final.json`, an exclusion override)."""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

from pcbdata.errors import UserError
from pcbdata.hashing import sha256_file

MISSING_INPUT = "missing_input"
LOAD_FAILURE = "load_failure"
UPGRADE_FAILURE = "upgrade_failure"
ENGINE_FAILURE = "engine_failure"
DRC_FAILURE = "drc_failure"
NOT_CONNECTED = "not_connected"
EXCLUDED = "excluded_by_override"
KEPT = "kept"
FATES = [MISSING_INPUT, LOAD_FAILURE, UPGRADE_FAILURE, ENGINE_FAILURE, DRC_FAILURE,
         NOT_CONNECTED, EXCLUDED, KEPT]


@dataclass
class SourceBoard:
    name: str
    folder: Path
    board_path: Path
    board_sha256: str = ""
    final_sha256: str = ""
    metadata_sha256: str = ""
    nets: int = 0
    pads: int = 0
    final_layers: int = 0
    metadata: dict | None = None
    fate: str = ""  # set here only for fates known without KiCad
    reason: str = ""
    notes: list[str] = field(default_factory=list)


def read_routing(path: Path) -> tuple[int, int, int]:
    """(nets, terminal pads, layers) of a `final.json`; raises ValueError with the reason."""
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"final.json is not UTF-8 ({exc.reason} at byte {exc.start})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"final.json is not valid JSON ({exc.msg}, line {exc.lineno})") from None
    nets = data.get("nets") if isinstance(data, dict) else None
    if not isinstance(nets, dict):
        raise ValueError("final.json has no nets table")
    pads = 0
    for pad_list in nets.values():
        if not isinstance(pad_list, list):
            raise ValueError("final.json: a net is not a list of pads")
        pads += len(pad_list)
    layers = data.get("layers")
    return len(nets), pads, len(layers) if isinstance(layers, list) else 0


def _read_metadata(path: Path) -> dict | None:
    try:
        data = json.loads(path.read_bytes().decode("utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return data if isinstance(data, dict) else None


def scan(source: str | Path, recipe) -> list[SourceBoard]:
    """Every board folder of a PCBench checkout, sorted by name."""
    src = recipe.source
    root = Path(source) / src.boards_dir
    if not root.is_dir():
        raise UserError(f"{source}: not a PCBench checkout (no {src.boards_dir}/ folder)")
    excluded = {o.board: o.reason for o in recipe.overrides("exclude")}
    boards = []
    for folder in sorted((p for p in root.iterdir() if p.is_dir()), key=lambda p: p.name):
        board = SourceBoard(name=folder.name, folder=folder,
                            board_path=folder / src.board_file)
        final = folder / src.routing_file
        meta = folder / src.metadata_file
        if meta.is_file():
            board.metadata_sha256 = sha256_file(meta)
            board.metadata = _read_metadata(meta)
        missing = [p.name for p in (board.board_path, final) if not p.is_file()]
        if board.board_path.is_file():
            board.board_sha256 = sha256_file(board.board_path)
        if final.is_file():
            board.final_sha256 = sha256_file(final)
        if missing:
            board.fate, board.reason = MISSING_INPUT, "no " + " and no ".join(missing)
        else:
            try:
                board.nets, board.pads, board.final_layers = read_routing(final)
            except (OSError, ValueError) as exc:
                board.fate, board.reason = LOAD_FAILURE, str(exc)
        if not board.fate and board.name in excluded:
            board.fate, board.reason = EXCLUDED, excluded[board.name]
        boards.append(board)
    return boards


def snapshot_sha256(boards: list[SourceBoard]) -> str:
    """One hash of the source: every board's name and input-file hashes, in name order."""
    digest = hashlib.sha256()
    for b in boards:
        digest.update(f"{b.name}\0{b.board_sha256}\0{b.final_sha256}\0"
                      f"{b.metadata_sha256}\n".encode())
    return digest.hexdigest()

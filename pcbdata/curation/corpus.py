"""Scanning a PCBench checkout: one `SourceBoard` per board folder, with the facts that need no
KiCad (hashes, `final.json` counts, metadata) and the fate it already has (missing input, an
unreadable `final.json`, an exclusion override)."""
from __future__ import annotations

import errno
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_file, sha256_text

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


def path_problem(path: Path, what: str) -> tuple[str, str] | None:
    """(fate, reason) when `path` cannot be read as a file (`what` names it in the reason):
    absent, a dangling or looping symbolic link, not a file; None when it is a file."""
    if path.is_file():
        return None
    if path.is_symlink():
        try:
            path.stat()
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                return LOAD_FAILURE, f"{what} is a symbolic link loop"
            return MISSING_INPUT, f"{what} is a dangling symbolic link (to {os.readlink(path)})"
    if path.exists():
        return MISSING_INPUT, f"{what} is not a file"
    return MISSING_INPUT, f"no {what}"


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
    except RecursionError:
        raise ValueError("final.json is nested too deeply to read") from None
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


def read_metadata(path: Path) -> tuple[dict | None, str]:
    """(metadata, problem) of a `metadata.json`: None and the reason when it is absent or
    cannot be used (then the board's attribution is unknown)."""
    problem = path_problem(path, "metadata.json")
    if problem:
        return None, problem[1]
    try:
        data = json.loads(path.read_bytes().decode("utf-8"))
    except OSError as exc:
        return None, f"metadata.json unreadable ({exc.strerror})"
    except UnicodeDecodeError as exc:
        return None, f"metadata.json is not UTF-8 ({exc.reason} at byte {exc.start})"
    except json.JSONDecodeError as exc:
        return None, f"metadata.json is not valid JSON ({exc.msg}, line {exc.lineno})"
    except RecursionError:
        return None, "metadata.json is nested too deeply to read"
    if not isinstance(data, dict):
        return None, "metadata.json is not a JSON object"
    wrong = [k for k in ("source", "author") if data.get(k) is not None
             and not isinstance(data[k], str)]
    if wrong:
        return ({k: v for k, v in data.items() if k not in wrong},
                f"metadata.json: {', '.join(wrong)} not text, ignored")
    return data, ""


def _scan_folder(board: SourceBoard, src) -> None:
    """Hashes, final.json counts, metadata and any fate known without KiCad, into `board`."""
    final = board.folder / src.routing_file
    meta = board.folder / src.metadata_file
    board.metadata, note = read_metadata(meta)
    if note and board.metadata is None:
        note += "; attribution unknown (licence NOASSERTION, not redistributable)"
    if note:
        board.notes.append(note)
    try:
        if meta.is_file():
            board.metadata_sha256 = sha256_file(meta)
        if board.board_path.is_file():
            board.board_sha256 = sha256_file(board.board_path)
        if final.is_file():
            board.final_sha256 = sha256_file(final)
    except OSError as exc:
        board.fate, board.reason = LOAD_FAILURE, f"{exc.filename}: {exc.strerror}"
        return
    problems = [p for p in (path_problem(board.board_path, src.board_file),
                            path_problem(final, src.routing_file)) if p]
    if problems:
        board.fate = LOAD_FAILURE if any(f == LOAD_FAILURE for f, _ in problems) else MISSING_INPUT
        board.reason = " and ".join(r for _, r in problems)
        return
    try:
        board.nets, board.pads, board.final_layers = read_routing(final)
    except (OSError, ValueError) as exc:
        board.fate, board.reason = LOAD_FAILURE, str(exc)


def _entry_problem(entry: Path, boards_dir: str) -> tuple[str, str] | None:
    """(fate, reason) of an entry of the boards folder that is not a usable folder."""
    if entry.is_dir():
        return None
    what = f"{boards_dir}/{entry.name}"
    problem = path_problem(entry, what)
    if problem and problem[1] != f"no {what}":
        return problem
    return MISSING_INPUT, f"{what} is a file, not a board folder"


#: Files of PCBench's own layout in its boards folder (the index of all boards): not boards.
#: Kept out of the recipe, whose bytes the released manifests pin.
LAYOUT_FILES = frozenset({"master_metadata.json"})


def scan(source: str | Path, recipe) -> list[SourceBoard]:
    """Every entry of a PCBench checkout's boards folder, sorted by name, but PCBench's own
    `LAYOUT_FILES`. Entries that are not usable folders (dangling or looping links, stray
    files) are boards with a fate too, so every entry is counted and has a reason."""
    src = recipe.source
    root = Path(source) / src.boards_dir
    if not root.is_dir():
        raise UserError(f"{source}: not a PCBench checkout (no {src.boards_dir}/ folder)")
    excluded = {o.board: o.reason for o in recipe.overrides("exclude")}
    boards = []
    for entry in sorted(root.iterdir(), key=lambda p: p.name):
        if entry.name in LAYOUT_FILES and entry.is_file() and not entry.is_symlink():
            continue
        board = SourceBoard(name=entry.name, folder=entry, board_path=entry / src.board_file)
        problem = _entry_problem(entry, src.boards_dir)
        if problem:
            board.fate, board.reason = problem
        else:
            _scan_folder(board, src)
        if not board.fate and board.name in excluded:
            board.fate, board.reason = EXCLUDED, excluded[board.name]
        boards.append(board)
    return boards


def snapshot_sha256(boards: list[SourceBoard]) -> str:
    """One hash of the source: every board's name and input-file hashes, in name order."""
    return sha256_text("".join(f"{b.name}\0{b.board_sha256}\0{b.final_sha256}\0"
                               f"{b.metadata_sha256}\n" for b in boards))

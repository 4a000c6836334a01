"""A built split's board folders against its manifest: every file with its sha256, nothing
missing, nothing extra, no leftovers of an interrupted run (`pcbdata verify`, and the check a
report records of the split it scored, `pcbdata.sets.identity`)."""
from __future__ import annotations

from pathlib import Path

from pcbdata.core.fsutil import sha256_file
from pcbdata.core.tree import REFERENCE_FILE


def is_leftover(name: str) -> bool:
    """A temporary file or folder of `fsutil.write_atomic` / `write_dir_atomic`."""
    return name.startswith(".") and name.endswith(".tmp")


def check_split(split_dir: Path, where: str, boards: dict,
                references_pending: bool = False) -> list[str]:
    if not split_dir.is_dir():
        if boards:  # an empty split (e.g. a tier a small corpus leaves empty) has no folder
            return [f"{where}: split folder missing ({len(boards)} boards)"]
        return []
    problems: list[str] = []
    on_disk = {p.name for p in split_dir.iterdir()}
    for board_id, board in sorted(boards.items()):
        if board_id not in on_disk:
            problems.append(f"{where}/{board_id}: board missing")
        else:
            pending = references_pending and "reference_routing" not in board
            problems += _check_board(split_dir / board_id, f"{where}/{board_id}", board["files"],
                                     pending)
    for extra in sorted(on_disk - set(boards)):
        what = ("leftover of an interrupted run" if is_leftover(extra)
                else "extra entry not in the manifest")
        problems.append(f"{where}/{extra}: {what}")
    return problems


def _check_board(board_dir: Path, where: str, files: dict[str, str],
                 reference_pending: bool = False) -> list[str]:
    if not board_dir.is_dir():
        return [f"{where}: not a folder"]
    problems: list[str] = []
    for name, sha in sorted(files.items()):
        problems += check_file(board_dir / name, sha, f"{where}/{name}")
    for extra in sorted({p.name for p in board_dir.iterdir()} - set(files)):
        why = ("routed after the manifest was written (reference routing unfinished)"
               if reference_pending and extra == REFERENCE_FILE
               else "extra file not in the manifest")
        problems.append(f"{where}/{extra}: {why}")
    return problems


def check_file(path: Path, sha: str, where: str) -> list[str]:
    if not path.is_file():
        return [f"{where}: file missing"]
    actual = sha256_file(path)
    if actual != sha:
        return [f"{where}: altered (sha256 {actual[:12]}..., manifest says {sha[:12]}...)"]
    return []

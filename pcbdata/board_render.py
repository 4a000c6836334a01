"""`pcbdata render`: PNG pictures of boards (routed or bare) with `pcbdata.core.drawing`.

KiCad reads each board into plain records in `KicadPool` workers
(`pcbdata.kicad.board_records`); drawing and writing happen here. A board that cannot be read
(missing, cut, not loadable) gives a reason for its picture; the others are still drawn.
"""
from __future__ import annotations

import csv
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pcbdata.core.drawing import draw_board, png_bytes, side_by_side
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import output_folder, write_atomic
from pcbdata.core.sexpr_text import cut_problem
from pcbdata.core.tree import BOARD_FILE, REFERENCE_FILE, board_dir
from pcbdata.kicad import KicadPool

READ = "pcbdata.kicad.board_records:read_board"
#: Pixels of one panel (width, height); a picture with a reference has two panels.
PANEL_SIZE = (640, 480)


@dataclass
class Picture:
    """One PNG to write: `name` (its path under OUT, without `.png`) and its panels
    (title, board file), drawn side by side."""

    name: str
    panels: list[tuple[str, Path]] = field(default_factory=list)


def boards_under(target: Path) -> list[Picture]:
    """A `.kicad_pcb` file, or every `.kicad_pcb` under a folder (a set tree, a RUNS folder),
    one picture each, named by its path under the folder."""
    if target.is_file():
        if target.suffix != ".kicad_pcb":
            raise UserError(f"{target}: not a .kicad_pcb file or a folder of boards")
        return [Picture(target.stem, [(target.stem, target)])]
    if not target.is_dir():
        raise UserError(f"{target}: no such file or folder")
    found = sorted(target.rglob("*.kicad_pcb"))
    if not found:
        raise UserError(f"{target}: holds no .kicad_pcb files")
    pictures = []
    for path in found:
        rel = path.relative_to(target).with_suffix("")
        pictures.append(Picture(rel.as_posix(), [(rel.as_posix(), path)]))
    return pictures


def _best_rollouts(report: Path) -> list[tuple[str, str | None]]:
    """(board_id, best rollout or None) from an eval report's per_board.csv."""
    table = report / "per_board.csv"
    if not table.is_file():
        raise UserError(f"--report {report}: no per_board.csv (a `pcbdata eval` report folder)")
    with open(table, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    if rows and not {"board_id", "best_rollout"} <= set(rows[0]):
        raise UserError(f"{table}: no board_id/best_rollout columns")
    return [(r["board_id"], r["best_rollout"] or None) for r in rows]


def best_of_report(runs: Path, report: Path, instances: Path | None) -> list[Picture]:
    """Per board of the report, its best rollout (RUNS/<board_id>/<best>.kicad_pcb) next to
    the reference routing of `instances` (the set's config/split folder) when the instance has
    one; boards without a scored rollout are drawn bare (the task) with a note in the title."""
    if not runs.is_dir():
        raise UserError(f"{runs}: no such RUNS folder")
    pictures = []
    for board_id, best in _best_rollouts(report):
        picture = Picture(board_id)
        if best is not None:
            picture.panels.append((f"{board_id} rollout {best}", runs / board_id /
                                   f"{best}.kicad_pcb"))
        folder = instances / board_id if instances is not None else None
        if folder is not None and (folder / REFERENCE_FILE).is_file():
            picture.panels.append((f"{board_id} reference", folder / REFERENCE_FILE))
        elif folder is not None and best is None:
            picture.panels.append((f"{board_id} task (no scored rollout)", folder / BOARD_FILE))
        if picture.panels:
            pictures.append(picture)
    return pictures


def _precheck(path: Path) -> str | None:
    """Why KiCad should not be given this file, or None (KiCad's parser can spin on a cut
    file, so it is checked here first)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        return f"{path}: cannot read ({exc.strerror or exc})"
    problem = cut_problem(data)
    return f"{path}: {problem}" if problem else None


def rules_for(path: Path, instances: Path | None) -> tuple[str | None, str | None]:
    """(project, custom rules) a board is checked with: its instance's (`instances` /
    <folder name>, for RUNS/<board_id>/<rollout>.kicad_pcb), else those beside it
    (board.kicad_pro / .kicad_dru of a set's board folder, or <stem>.kicad_pro); (None, None):
    KiCad's defaults."""
    folder = instances / path.parent.name if instances is not None else path.parent
    if not folder.is_dir():
        folder = path.parent
    for stem in ("board", path.stem):
        project = folder / f"{stem}.kicad_pro"
        if project.is_file():
            rules = folder / f"{stem}.kicad_dru"
            return str(project), str(rules) if rules.is_file() else None
    return None, None


def iter_records(paths: list[Path], pool: KicadPool, drc: bool = False,
                 instances: Path | None = None) -> Iterator[tuple[Path, dict | str]]:
    """(board file, records or the reason) as the boards are read in `pool`'s workers (files
    that fail the pre-check first); with `drc`, DRC error markers (see `rules_for`)."""
    todo = []
    for path in paths:
        problem = _precheck(path)
        if problem:
            yield path, problem
        else:
            todo.append(path)
    args = [(str(p), *rules_for(p, instances), True) if drc else (str(p),) for p in todo]
    for outcome in pool.map(READ, args):
        path = todo[outcome.index]
        yield path, outcome.value if outcome.ok else f"{path}: {outcome.error}"


def read_boards(paths: list[Path], pool: KicadPool) -> dict[Path, dict | str]:
    """Records (dict) or the reason (str) per board file."""
    return dict(iter_records(paths, pool))


def draw_picture(picture: Picture, records: dict[Path, dict | str],
                 size: tuple[int, int] = PANEL_SIZE) -> np.ndarray | str:
    """The picture (RGB array), or the reason it cannot be drawn."""
    images, titles = [], []
    for title, path in picture.panels:
        got = records[path]
        if isinstance(got, str):
            return got
        images.append(draw_board(got, size))
        drc = f", {len(got['markers'])} DRC errors" if "markers" in got else ""
        titles.append(f"{title}: {len(got['ratsnest'])} open{drc}")
    return side_by_side(images, titles)


def render_boards(target: str | Path, out: str | Path, *, report: str | Path | None = None,
                  instances: str | Path | None = None, workers: int = 2,
                  timeout: float = 120.0, size: tuple[int, int] = PANEL_SIZE,
                  drc: bool = False, log: Callable[[str], None] = print) -> dict:
    """Draws the boards of `target` (see `boards_under`; with `report`, `best_of_report`) into
    OUT/<name>.png, with `drc` KiCad's DRC errors as markers. Returns {"written", "failed":
    [reasons], "seconds"}."""
    began = time.perf_counter()
    target = Path(target)
    if report is not None:
        pictures = best_of_report(target, Path(report),
                                  Path(instances) if instances is not None else None)
    else:
        pictures = boards_under(target)
    out = output_folder(out)
    users: dict[Path, list[int]] = {}  # board file -> the pictures that show it
    for k, picture in enumerate(pictures):
        for path in {path for _, path in picture.panels}:
            users.setdefault(path, []).append(k)
    missing = [len({path for _, path in picture.panels}) for picture in pictures]
    left = {path: len(ks) for path, ks in users.items()}
    records: dict[Path, dict | str] = {}
    written, failed = 0, []
    with KicadPool(workers=max(1, min(workers, len(users))), task_timeout=timeout) as pool:
        # Each picture is drawn as soon as its boards are read; a board's records are dropped
        # once every picture showing it is drawn (a big set is never held in memory whole).
        rules = Path(instances) if instances is not None else None
        for path, got in iter_records(sorted(users), pool, drc, rules):
            records[path] = got
            for k in users[path]:
                missing[k] -= 1
                if missing[k]:
                    continue
                picture = pictures[k]
                problem = _write(picture, records, out, size)
                written += problem is None
                failed += [f"{picture.name}: {problem}"] if problem else []
                done = f"[{written + len(failed)}/{len(pictures)}] {picture.name}"
                log(f"{done}: not drawn ({problem})" if problem else f"{done}.png")
                for shown in {q for _, q in picture.panels}:
                    left[shown] -= 1
                    if not left[shown]:
                        del records[shown]
    return {"written": written, "failed": failed, "seconds": time.perf_counter() - began}


def _write(picture: Picture, records: dict[Path, dict | str], out: Path,
           size: tuple[int, int]) -> str | None:
    """Draws and writes one picture; the reason it cannot be drawn, or None."""
    result = draw_picture(picture, records, size)
    if isinstance(result, str):
        return result
    destination = out / f"{picture.name}.png"
    destination.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(destination, png_bytes(result))
    return None


def instance_folder(set_root: str | Path, config: str, split: str) -> Path:
    """The set's config/split folder (instances and references), checked."""
    folder = board_dir(set_root, config, split, "x").parent
    if not folder.is_dir():
        raise UserError(f"--set {set_root}: no {config}/{split} folder")
    return folder

"""Where an environment's boards come from (its generator, in jumanji's words): a built set
folder, dataset rows, or a family's generator called on the fly. Each is a `BoardSource`."""
from __future__ import annotations

import shutil
from pathlib import Path
from typing import Protocol

from pcbdata.core.errors import UserError
from pcbdata.core.tree import INSTANCE_FILES
from pcbdata.sets.configs import ConfigSpec


class BoardSource(Protocol):
    """The boards an environment draws from.

    Guarantee: `board_ids` is fixed for the source's life and in a deterministic order, and
    `folder(i, work)` returns a folder holding board i's instance files (`board.kicad_pcb`,
    `board.kicad_pro` and, where the family has custom rules, `board.kicad_dru`), the same
    bytes on every call and in every process; it may write them under `work`, a folder of the
    environment's own."""

    board_ids: list[str]

    def folder(self, index: int, work: Path) -> Path: ...


class SetSource:
    """Boards of `root/<config>/<split>/<board_id>/` (a built set), in board-id order."""

    def __init__(self, root, config: str, split: str):
        from pcbdata.core.tree import list_instances

        listed = list_instances(Path(root), config, split)
        self.board_ids = [board_id for board_id, _ in listed]
        self._dirs = [folder for _, folder in listed]

    def folder(self, index: int, work: Path) -> Path:
        return self._dirs[index]


class RowSource:
    """Boards of dataset rows (`datasets.load_dataset(...)` or any list of row dicts);
    recipe rows (no board text) are left out."""

    def __init__(self, rows):
        self._rows = [row for row in rows if row.get("board") is not None]
        if not self._rows:
            raise UserError("the dataset rows hold no board (recipe rows only?)")
        self.board_ids = [row["board_id"] for row in self._rows]

    def folder(self, index: int, work: Path) -> Path:
        from pcbdata.publish import materialize_row

        target = work / "instance"
        shutil.rmtree(target, ignore_errors=True)
        written = materialize_row(self._rows[index], target, layout="flat")
        return written


class GeneratorSource:
    """D1/D2 boards generated on the fly, board i of the split exactly as `pcbdata build`
    writes it (same seed stream)."""

    def __init__(self, spec: ConfigSpec, split: str, count: int | None):
        if not spec.synthetic:
            raise UserError(f"config {spec.name!r} has no generator: pass root=<a built set> "
                            f"(`pcbdata build d3`) or rows=<dataset rows>")
        if split not in spec.splits:
            raise UserError(f"config {spec.name!r} has no split {split!r} "
                            f"(splits: {', '.join(spec.splits)})")
        self._spec = spec
        self._split = split
        self._generator = spec.generator()
        total = _split_size(spec, split)
        self.board_ids = [f"board_{i:05d}" for i in range(min(count or total, total))]

    def folder(self, index: int, work: Path) -> Path:
        from pcbdata.model.kicad_writer import board_files

        assert self._spec.seed is not None  # synthetic configs have a seed
        instance = self._generator.generate(self._spec.seed, self._split, index)
        target = work / "instance"
        shutil.rmtree(target, ignore_errors=True)
        target.mkdir(parents=True)
        for name, text in board_files(instance.board).items():
            (target / name).write_text(text, encoding="utf-8")
        return target


def _split_size(spec: ConfigSpec, split: str) -> int:
    return int(spec.sizes[split])


def make_source(spec: ConfigSpec, root, split: str, rows, count: int | None) -> BoardSource:
    if rows is not None:
        return RowSource(rows)
    if root is not None:
        return SetSource(root, spec.name, split)
    return GeneratorSource(spec, split, count)


def instance_files(folder: Path) -> tuple[str, str, str | None]:
    """(board, project, custom rules or None) of an instance folder."""
    board, project, rules = (folder / name for name in INSTANCE_FILES)
    if not board.is_file() or not project.is_file():
        raise UserError(f"{folder}: not an instance folder (needs board.kicad_pcb and "
                        f"board.kicad_pro)")
    return str(board), str(project), str(rules) if rules.is_file() else None

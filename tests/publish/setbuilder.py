"""Small real board sets for the publication tests: D1, D2 and a D3-shaped config, written
with the real generators and KiCad writer and a manifest that follows `pcbdata.model.manifest`."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from pcbdata.core.fsutil import write_atomic
from pcbdata.core.hashing import sha256_bytes
from pcbdata.generators.d1 import D1Generator, D1Params
from pcbdata.generators.d2 import D2Generator
from pcbdata.model import kicad_writer
from pcbdata.model.manifest import FORMAT, write_manifest
from pcbdata.sets import presets

SIZES = {"train": 4, "validation": 2, "test": 3}


def _write_board(folder: Path, files: dict[str, str]) -> dict[str, str]:
    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    for name, text in files.items():
        data = text.encode("utf-8")
        (folder / name).write_bytes(data)
        out[name] = sha256_bytes(data)
    return out


def _d2_config(root: Path, sizes: dict[str, int]) -> dict:
    level = presets.level("d2", "default")
    gen = D2Generator(level.params)
    splits = {}
    for split, count in sizes.items():
        boards = {}
        for index in range(count):
            inst = gen.generate(level.seed, split, index)
            files = _write_board(root / "d2" / split / inst.board_id,
                                 kicad_writer.board_files(inst.board))
            boards[inst.board_id] = {"files": files, **inst.facts(gen.routing_layers)}
        splits[split] = {"count": count, "kicad_checked": False, "boards": boards}
    return {"family": "d2", "set_version": level.version, "parameters": level.params.as_dict(),
            "seed": level.seed, "level": level.name, "splits": splits}


def _d1_config(root: Path, grid: int, sizes: dict[str, int]) -> dict:
    params = D1Params(grid=grid)
    gen = D1Generator(params)
    config = f"d1-g{grid}"
    splits = {}
    for split, count in sizes.items():
        boards, starts, targets, ids = {}, [], [], []
        for index in range(count):
            inst = gen.generate(0, split, index)
            files = _write_board(root / config / split / inst.board_id,
                                 kicad_writer.board_files(inst.board))
            boards[inst.board_id] = {"files": files, **inst.facts(gen.routing_layers)}
            ids.append(inst.board_id)
            starts.append([list(s) for s, _ in inst.cells])
            targets.append([list(t) for _, t in inst.cells])
        buf = io.BytesIO()
        np.savez(buf, starts=np.array(starts, dtype=np.int32),
                 targets=np.array(targets, dtype=np.int32),
                 board_ids=np.array(ids), grid_size=np.int32(grid), num_agents=np.int32(5),
                 connector_version=np.array("test"))
        write_atomic(root / config / f"{split}.npz", buf.getvalue())
        splits[split] = {"count": count, "kicad_checked": False, "boards": boards,
                         "arrays": {f"{split}.npz": sha256_bytes(buf.getvalue())}}
    return {"family": "d1", "set_version": "1.0.0", "parameters": params.as_dict(), "seed": 0,
            "splits": splits}


def _d3_config(root: Path, config: str, count: int = 4) -> dict:
    """A D3-shaped config (splits test + full, per-board attribution, one recipe board) made
    from generated boards: the publication code only sees files and manifest entries."""
    level = presets.level("d2", "medium")
    gen = D2Generator(level.params)
    full, test = {}, {}
    for index in range(count):
        inst = gen.generate(7, "train", index)
        name = f"project_{index}"
        board_id = f"{index + 1:04d}_{name}"
        files = kicad_writer.board_files(inst.board)
        files["reference.kicad_pcb"] = files["board.kicad_pcb"]
        entry_files = {}
        for split in ("full", "test") if index % 2 == 0 else ("full",):
            entry_files = _write_board(root / config / split / board_id, files)
        facts = inst.facts(2)
        # the shape of `pcbdata.build.d3`'s manifest entries
        entry = {"files": entry_files, "name": name, "row": index + 1, "pads": facts["n_pads"],
                 "nets": facts["n_nets"], "components": facts["n_components"], "layers": 2,
                 "source_board_sha256": "ab" * 32,
                 "source_repository": f"https://github.com/example/{name}",
                 "author": f"Author {index}",
                 "licence": "CC-BY-4.0" if index != 2 else "unknown",
                 "redistributable": index != 2, "compat_board_identical": True}
        full[board_id] = entry
        if index % 2 == 0:
            test[board_id] = entry
    return {"family": "d3", "set_version": "1.0.0", "tier": config[-1].upper(),
            "recipe": {"name": "test-recipe", "version": "1.0.0", "sha256": "cd" * 32},
            "parameters": {"recipe": "test-recipe", "tier": config}, "kicad_version": "9.0.8",
            "splits": {"test": {"count": len(test), "kicad_checked": False, "boards": test},
                       "full": {"count": len(full), "kicad_checked": False, "boards": full}}}


def make_set(root: Path, d2: dict | None = None, d1: dict | None = None, d3: bool = True) -> dict:
    """Writes a small complete built set at `root` (tree + manifest; not published)."""
    root = Path(root)
    configs = {"d2": _d2_config(root, d2 or SIZES), "d1-g10": _d1_config(root, 10, d1 or SIZES)}
    if d3:
        configs["d3-b"] = _d3_config(root, "d3-b")
    manifest = {"format": FORMAT, "package_version": "0.1.0", "kicad_version": "9.0.8",
                "configs": configs}
    write_manifest(root, manifest)
    return manifest

"""Small board sets for tests and benchmarks: generated boards of a config (`write_set`) and
the manifest of a hand-made set (`seal_set`), so the evaluator and the environment take it as
a verified set."""
from __future__ import annotations

from pathlib import Path


def write_board(folder: Path, board) -> Path:
    """Writes a `pcbdata.model.board.Board`'s files into `folder`; returns its board file."""
    from pcbdata.model.kicad_writer import board_files

    folder.mkdir(parents=True, exist_ok=True)
    for name, text in board_files(board).items():
        (folder / name).write_text(text)
    return folder / "board.kicad_pcb"


def write_set(root: Path, config: str, split: str, count: int) -> Path:
    """The first `count` boards of a synthetic config's split, written as `pcbdata build
    --no-check` writes them (same bytes), with a manifest (`seal_set`): a set in seconds."""
    from pcbdata.model.kicad_writer import board_files
    from pcbdata.sets.configs import get_config

    spec = get_config(config)
    if spec.seed is None:
        raise ValueError(f"config {config!r} has no generator (D3 boards are curated)")
    generator = spec.generator()
    for index in range(count):
        instance = generator.generate(spec.seed, split, index)
        folder = root / config / split / instance.board_id
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in board_files(instance.board).items():
            (folder / name).write_text(text, encoding="utf-8")
    return seal_set(root)


def seal_set(root: Path) -> Path:
    """Writes the manifest of a hand-made set (`root/<config>/<split>/<board>/<files>`) as a
    build would, listing every file on disk with its sha256, so the evaluator and the
    environment take it as a verified set. A config the registry knows records its family,
    version, seed and parameters; the others are `d2` boards under another name."""
    from pcbdata.core.errors import UserError
    from pcbdata.core.hashing import sha256_file
    from pcbdata.model.manifest import FORMAT, write_manifest
    from pcbdata.sets.configs import get_config

    configs: dict = {}
    for split_dir in sorted(p for p in Path(root).glob("*/*") if p.is_dir()):
        boards = {b.name: {"files": {f.name: sha256_file(f) for f in sorted(b.iterdir())}}
                  for b in sorted(split_dir.iterdir()) if b.is_dir()}
        name = split_dir.parent.name
        if name not in configs:
            try:
                spec = get_config(name)
                configs[name] = {"family": spec.family, "set_version": spec.version,
                                 "seed": spec.seed, "parameters": spec.parameters,
                                 **spec.manifest, "splits": {}}
            except UserError:
                configs[name] = {"family": "d2", "set_version": "test", "splits": {}}
        configs[name]["splits"][split_dir.name] = {"boards": boards, "count": len(boards)}
    write_manifest(root, {"format": FORMAT, "package_version": "test", "configs": configs})
    return Path(root)

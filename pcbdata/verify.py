"""Checks a built board set against its manifest: every file's sha256, nothing missing, nothing
extra, no leftovers of an interrupted run, and (when published) the parquet rows and card."""
from __future__ import annotations

from pathlib import Path

from pcbdata.fsutil import sha256_file
from pcbdata.manifest import MANIFEST_NAME, read_manifest


def verify_set(root: str | Path) -> list[str]:
    """Problems found, one line each, naming the board and file; empty when the set is intact."""
    root = Path(root)
    manifest = read_manifest(root)
    problems: list[str] = []
    known_top = {MANIFEST_NAME, ".pcbdata"}
    for config_name, config in sorted(manifest["configs"].items()):
        known_top.add(config_name)
        config_dir = root / config_name
        known_in_config: set[str] = set()
        for split_name, split in sorted(config["splits"].items()):
            known_in_config.add(split_name)
            for array_name, sha in split.get("arrays", {}).items():
                known_in_config.add(array_name)
                problems += _check_file(config_dir / array_name, sha, f"{config_name}/{array_name}")
            split_dir = config_dir / split_name
            if not split_dir.is_dir():
                if split["boards"]:  # an empty split (e.g. a tier a small corpus leaves empty) has none
                    problems.append(f"{config_name}/{split_name}: split folder missing "
                                    f"({len(split['boards'])} boards)")
                continue
            on_disk = {p.name for p in split_dir.iterdir()}
            for board_id, board in sorted(split["boards"].items()):
                where = f"{config_name}/{split_name}/{board_id}"
                board_dir = split_dir / board_id
                if board_id not in on_disk:
                    problems.append(f"{where}: board missing")
                    continue
                files = board["files"]
                for name, sha in sorted(files.items()):
                    problems += _check_file(board_dir / name, sha, f"{where}/{name}")
                for extra in sorted({p.name for p in board_dir.iterdir()} - set(files)):
                    problems.append(f"{where}/{extra}: extra file not in the manifest")
            for extra in sorted(on_disk - set(split["boards"])):
                problems.append(f"{config_name}/{split_name}/{extra}: extra entry not in the manifest")
        if config_dir.is_dir():
            problems += [f"{config_name}/{p.name}: leftover of an interrupted run"
                         for p in sorted(config_dir.iterdir()) if p.name.endswith(".tmp")]
    problems += _published_problems(root, manifest)
    return problems


def _check_file(path: Path, sha: str, where: str) -> list[str]:
    if not path.is_file():
        return [f"{where}: file missing"]
    actual = sha256_file(path)
    if actual != sha:
        return [f"{where}: altered (sha256 {actual[:12]}..., manifest says {sha[:12]}...)"]
    return []


def _published_problems(root: Path, manifest: dict) -> list[str]:
    from pcbdata.publish import verify_published

    problems = [f"{p.name}: leftover of an interrupted publish" for p in sorted(root.glob(".*.tmp"))]
    if (root / "README.md").exists() or (root / "publish.json").exists():
        problems += verify_published(root, manifest)
    return problems

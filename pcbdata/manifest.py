"""The manifest of a built board set: `DIR/manifest.json`.

Schema (format "pcbdata-manifest/1"); all keys sorted, no timestamps, so that the same build
gives the same bytes:

    {"format", "package_version", "kicad_version",
     "configs": {<config>: {"family", "set_version", "parameters", "seed", "seed_scheme", ...,
                            "splits": {<split>: {"count", "kicad_checked",
                                                 "arrays": {<file name>: sha256},   # optional
                                                 "boards": {<board_id>: {"files": {<name>: sha256},
                                                                         <fact>: value, ...}}}}}}}

Files of a board live in `DIR/<config>/<split>/<board_id>/`; split-level arrays in
`DIR/<config>/`. A set is complete exactly when its manifest exists: the manifest is written
last, atomically.
"""
from __future__ import annotations

import json
from pathlib import Path

from pcbdata.errors import UserError
from pcbdata.fsutil import write_atomic

MANIFEST_NAME = "manifest.json"
FORMAT = "pcbdata-manifest/1"


def manifest_path(root: str | Path) -> Path:
    return Path(root) / MANIFEST_NAME


def dumps(manifest: dict) -> str:
    return json.dumps(manifest, indent=1, sort_keys=True, ensure_ascii=False) + "\n"


def read_manifest(root: str | Path) -> dict:
    path = manifest_path(root)
    if not path.is_file():
        raise UserError(f"{path}: no manifest; is {root} a complete pcbdata board set?")
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: not a valid manifest ({exc})") from None
    if manifest.get("format") != FORMAT:
        raise UserError(f"{path}: unknown manifest format {manifest.get('format')!r}")
    return manifest


def write_manifest(root: str | Path, manifest: dict) -> None:
    write_atomic(manifest_path(root), dumps(manifest))


def merge_configs(root: str | Path, base: dict, configs: dict) -> dict:
    """The manifest of `root` with `configs` added or replaced (a folder can hold many configs)."""
    path = manifest_path(root)
    merged = dict(base)
    merged["configs"] = {}
    if path.is_file():
        old = read_manifest(root)
        merged["configs"].update(old.get("configs", {}))
    merged["configs"].update(configs)
    return merged

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
`DIR/<config>/` (`pcbdata.core.tree`). A set is complete exactly when its manifest exists: the
manifest is written last, atomically.

**One vocabulary of board facts** (`BOARD_FACTS`, the parquet columns): `n_nets`, `n_pads`,
`n_components`, `n_layers`, `routing_layers`, `width_mm`, `height_mm`. D1/D2 entries store them
under these names. D3 entries of format 1 store four of them under the names of the D3
characteristics table (`nets`, `pads`, `components`, `layers`); the released D3 manifests pin
those bytes, so renaming them would need a new manifest format and new releases. The mapping
therefore lives here, once (`D3_FACT_NAMES`): the D3 build writes entries through it
(`d3_facts`), every reader goes through `board_fact`. A format 2 would store `BOARD_FACTS` for
every family and drop the mapping.
"""
from __future__ import annotations

import json
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import write_atomic
from pcbdata.core.textio import canonical_json
from pcbdata.core.tree import MANIFEST_NAME, manifest_path

__all__ = ["FORMAT", "MANIFEST_NAME", "BOARD_FACTS", "D3_FACT_NAMES", "manifest_path", "dumps",
           "read_manifest", "write_manifest", "merge_configs", "board_fact", "d3_facts"]

FORMAT = "pcbdata-manifest/1"
BOARD_FACTS = ("n_nets", "n_pads", "n_components", "n_layers", "routing_layers", "width_mm",
               "height_mm")
#: Where D3 entries (format 1) store four of the `BOARD_FACTS`.
D3_FACT_NAMES = {"n_nets": "nets", "n_pads": "pads", "n_components": "components",
                 "n_layers": "layers"}


def board_fact(entry: dict, key: str):
    """A fact of `BOARD_FACTS` of one board entry, whichever family wrote it (None if absent)."""
    value = entry.get(key)
    if value is None and key in D3_FACT_NAMES:
        value = entry.get(D3_FACT_NAMES[key])
    return value


def d3_facts(nets: int, pads: int, components: int, layers: int) -> dict:
    """The facts of a D3 board entry, under the names format 1 stores them."""
    return {D3_FACT_NAMES["n_nets"]: nets, D3_FACT_NAMES["n_pads"]: pads,
            D3_FACT_NAMES["n_components"]: components, D3_FACT_NAMES["n_layers"]: layers}


def dumps(manifest: dict) -> str:
    return canonical_json(manifest)


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

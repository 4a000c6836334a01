"""Rows of the parquet shards, made from the manifest and the board tree.

One row per board. Columns, in order:

- identity: `config`, `split`, `board_id`, `family`, `set_version`;
- facts: `n_nets`, `n_pads`, `n_components`, `n_layers`, `routing_layers`, `width_mm`,
  `height_mm` (`pcbdata.model.manifest.BOARD_FACTS`, read with `board_fact` whichever family wrote
  the entry), then every other per-board fact of the manifest (D3: name, source, licence, ...),
  nested tables flattened to `outer_inner`, lists as JSON text;
- `redistributable` (False: a recipe row, whose file texts are null and whose hashes let
  `pcbdata build d3` restore and check the board);
- hashes: `sha256` (the board file), `project_sha256`, `custom_rules_sha256`, `reference_sha256`;
- generation: `parameters` (JSON text of the config's parameters or recipe), `seed`;
- D1 only: `grid_size`, `starts`, `targets` (the Connector arrays' cells, [5][2] int32);
- file texts (`large_string`): `board`, `project`, `custom_rules`, `reference`, and
  `other_files` (list of {name, text, sha256}) for any other file of a board folder.
"""
from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pyarrow as pa

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_bytes
from pcbdata.core.tree import arrays_path, board_dir
from pcbdata.model.manifest import BOARD_FACTS, D3_FACT_NAMES, board_fact
from pcbdata.publish.layout import FILE_COLUMNS

_FLOAT_FACTS = {"width_mm", "height_mm"}
KNOWN_FACTS = {name: pa.float64() if name in _FLOAT_FACTS else pa.int64() for name in BOARD_FACTS}
_RESERVED = {"config", "split", "board_id", "family", "set_version", "redistributable",
             "parameters", "seed", "grid_size", "starts", "targets", "other_files", "files",
             *KNOWN_FACTS, *(c for pair in FILE_COLUMNS.values() for c in pair)}
OTHER_FILE_TYPE = pa.struct([("name", pa.string()), ("text", pa.large_string()),
                             ("sha256", pa.string())])
CELLS_TYPE = pa.list_(pa.list_(pa.int32()))


def is_redistributable(entry: dict) -> bool:
    """A board may be published with its text unless its manifest entry says otherwise
    (`redistributable: false`, at top level or inside a nested table such as `source`)."""
    if "redistributable" in entry:
        return bool(entry["redistributable"])
    for value in entry.values():
        if isinstance(value, dict) and "redistributable" in value:
            return bool(value["redistributable"])
    return True


def _flat_facts(entry: dict) -> dict:
    out = {}
    for key, value in entry.items():
        if key in ("files", "redistributable") or key in KNOWN_FACTS:
            continue
        if key in D3_FACT_NAMES.values():
            continue  # a fact of BOARD_FACTS stored under its D3 name: a standard column
        if isinstance(value, dict):
            for sub, subvalue in value.items():
                if sub == "redistributable":
                    continue
                out[f"{key}_{sub}"] = subvalue
        else:
            out[key] = value
    renamed = {}
    for key, value in out.items():
        name = f"fact_{key}" if key in _RESERVED else key
        if isinstance(value, (list, dict)):
            value = json.dumps(value, sort_keys=True, ensure_ascii=False)
        renamed[name] = value
    return renamed


def _arrow_type(values: list) -> pa.DataType:
    kinds = {type(v) for v in values if v is not None}
    if not kinds or kinds <= {str}:
        return pa.string()
    if kinds <= {bool}:
        return pa.bool_()
    if kinds <= {int}:
        return pa.int64()
    if kinds <= {int, float}:
        return pa.float64()
    return pa.string()


def _coerce(value, typ: pa.DataType):
    if value is None:
        return None
    if typ == pa.string() and not isinstance(value, str):
        return json.dumps(value) if not isinstance(value, (int, float, bool)) else str(value)
    if typ == pa.float64():
        return float(value)
    return value


def _decode(data: bytes, where: Path) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UserError(f"{where}: not UTF-8 text ({exc}); the parquet rows carry text") from None


def read_cells(root: Path, config: str, split: str, split_entry: dict) -> dict | None:
    """D1: board_id -> (starts, targets) from `<config>/<split>.npz`, checked against its hash."""
    path = arrays_path(root, config, split)
    if not path.is_file():
        return None
    expected = (split_entry.get("arrays") or {}).get(path.name)
    data = path.read_bytes()
    if expected and sha256_bytes(data) != expected:
        raise UserError(f"{path}: sha256 differs from the manifest; rebuild the set")
    with np.load(io.BytesIO(data), allow_pickle=False) as arrays:
        ids = [str(b) for b in arrays["board_ids"]]
        starts = np.asarray(arrays["starts"], dtype=np.int32)
        targets = np.asarray(arrays["targets"], dtype=np.int32)
    return {bid: (starts[k].tolist(), targets[k].tolist()) for k, bid in enumerate(ids)}


def config_fact_types(config_entry: dict) -> dict[str, pa.DataType]:
    """The extra fact columns of a config (same for all its splits, so shards share a schema)."""
    values: dict[str, list] = {}
    for split_entry in config_entry.get("splits", {}).values():
        for entry in split_entry.get("boards", {}).values():
            for key, value in _flat_facts(entry).items():
                values.setdefault(key, []).append(value)
    return {key: _arrow_type(vals) for key, vals in sorted(values.items())}


def schema_for(config_entry: dict, has_cells: bool) -> pa.Schema:
    fields = [("config", pa.string()), ("split", pa.string()), ("board_id", pa.string()),
              ("family", pa.string()), ("set_version", pa.string())]
    fields += list(KNOWN_FACTS.items())
    fields += list(config_fact_types(config_entry).items())
    fields += [("redistributable", pa.bool_())]
    fields += [(digest, pa.string()) for _, digest in FILE_COLUMNS.values()]
    fields += [("parameters", pa.string()), ("seed", pa.int64())]
    if has_cells:
        fields += [("grid_size", pa.int32()), ("starts", CELLS_TYPE), ("targets", CELLS_TYPE)]
    fields += [(text, pa.large_string()) for text, _ in FILE_COLUMNS.values()]
    fields += [("other_files", pa.list_(OTHER_FILE_TYPE))]
    return pa.schema(fields)


def iter_rows(root: Path, config: str, config_entry: dict, split: str, has_cells: bool):
    """Yields (row dict, raw tree bytes of the board) for every board of one split."""
    split_entry = config_entry["splits"][split]
    cells = read_cells(root, config, split, split_entry) if has_cells else None
    params = json.dumps(config_entry.get("parameters", config_entry.get("recipe")),
                        sort_keys=True, ensure_ascii=False)
    grid = (config_entry.get("parameters") or {}).get("grid")
    extra_types = config_fact_types(config_entry)
    for board_id in sorted(split_entry.get("boards", {})):
        entry = split_entry["boards"][board_id]
        folder = board_dir(root, config, split, board_id)
        publish_text = is_redistributable(entry)
        row = {"config": config, "split": split, "board_id": board_id,
               "family": config_entry.get("family"), "set_version": config_entry.get("set_version"),
               "redistributable": publish_text,
               "parameters": params, "seed": config_entry.get("seed"), "other_files": []}
        for key in KNOWN_FACTS:
            row[key] = _coerce(board_fact(entry, key), KNOWN_FACTS[key])
        facts = _flat_facts(entry)
        for key, typ in extra_types.items():
            row[key] = _coerce(facts.get(key), typ)
        for text_col, hash_col in FILE_COLUMNS.values():
            row[text_col] = row[hash_col] = None
        raw = 0
        for name, digest in sorted(entry.get("files", {}).items()):
            path = folder / name
            if publish_text:
                try:
                    data = path.read_bytes()
                except FileNotFoundError:
                    raise UserError(f"{path}: listed in the manifest but missing; rebuild the "
                                    f"set or run `pcbdata verify {root}`") from None
                if sha256_bytes(data) != digest:
                    raise UserError(f"{path}: sha256 differs from the manifest (the board was "
                                    f"altered after the build); rebuild the set")
                raw += len(data)
                text = _decode(data, path)
            else:
                text = None
                if path.is_file():
                    raw += path.stat().st_size
            if name in FILE_COLUMNS:
                text_col, hash_col = FILE_COLUMNS[name]
                row[text_col], row[hash_col] = text, digest
            else:
                row["other_files"].append({"name": name, "text": text, "sha256": digest})
        if row["sha256"] is None:
            raise UserError(f"{config}/{split}/{board_id}: the manifest lists no board.kicad_pcb")
        if has_cells:
            if cells is None or board_id not in cells:
                raise UserError(f"{arrays_path(root, config, split)}: no Connector arrays for "
                                f"{board_id}; rebuild the set")
            row["grid_size"] = grid
            row["starts"], row["targets"] = cells[board_id]
        yield row, raw


def table_from_rows(rows: list[dict], schema: pa.Schema) -> pa.Table:
    columns = {field.name: [row.get(field.name) for row in rows] for field in schema}
    return pa.Table.from_pydict(columns, schema=schema)

"""Loading the versioned D3 recipe (`pcbdata/resources/recipes/d3.toml`, packaged in `pcbdata.resources`)."""
from __future__ import annotations

import hashlib
import tomllib
from dataclasses import dataclass
from pcbdata.resources import resource_path
from pathlib import Path

from pcbdata.errors import UserError

DEFAULT_RECIPE = "d3.toml"
OVERRIDE_KINDS = {"exclude", "exclude_from_test", "replace_pick"}
_REQUIRED = {
    "recipe": ["name", "version"],
    "source": ["boards_dir", "board_file", "routing_file", "metadata_file"],
    "engine": ["uuid_seed", "task_timeout_s"],
    "compat": ["ignore_severities", "rules", "min_hole_to_hole_cap", "spacing_probe_mm"],
    "keep": ["max_errors", "max_unconnected"],
    "tiers": ["a_size", "b_max_pads"],
    "picks": ["bins", "layers", "c_trim_fraction"],
    "licences": ["redistributable"],
}


@dataclass(frozen=True)
class Recipe:
    data: dict
    sha256: str
    source: str  # file name or path it was read from
    text: bytes

    @property
    def version(self) -> str:
        return str(self.data["recipe"]["version"])

    def __getitem__(self, key: str):
        return self.data[key]

    def overrides(self, kind: str) -> list[dict]:
        return [o for o in self.data.get("overrides", []) if o["kind"] == kind]


def parse_recipe(raw: bytes, source: str) -> Recipe:
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise UserError(f"{source}: not a valid recipe ({exc})") from None
    for table, keys in _REQUIRED.items():
        if not isinstance(data.get(table), dict):
            raise UserError(f"{source}: recipe has no [{table}] table")
        missing = [k for k in keys if k not in data[table]]
        if missing:
            raise UserError(f"{source}: [{table}] lacks {', '.join(missing)}")
    for entry in data.get("overrides", []):
        if entry.get("kind") not in OVERRIDE_KINDS:
            raise UserError(f"{source}: override kind {entry.get('kind')!r} is not one of "
                            f"{', '.join(sorted(OVERRIDE_KINDS))}")
        if not entry.get("board") or not str(entry.get("reason", "")).strip():
            raise UserError(f"{source}: every override needs a board and a reason")
        if entry["kind"] == "replace_pick" and not entry.get("replacement"):
            raise UserError(f"{source}: replace_pick override of {entry['board']} "
                            f"needs a replacement")
    return Recipe(data=data, sha256=hashlib.sha256(raw).hexdigest(), source=source, text=raw)


def load_recipe(path: str | Path | None = None) -> Recipe:
    """The recipe at `path`, or the packaged default recipe."""
    if path is None:
        raw = resource_path("recipes", DEFAULT_RECIPE).read_bytes()
        return parse_recipe(raw, DEFAULT_RECIPE)
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such recipe file")
    return parse_recipe(path.read_bytes(), str(path))

"""Loads the versioned generator presets: D1's (`presets/d1.toml`) and the levels of every
family with levels (its `Family.levels_file`: D2's `presets/d2_levels.toml`, D2R's
`presets/d2r_levels.toml`)."""
from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass
from typing import Any

from pcbdata.core.errors import UserError
from pcbdata.core.rng import check_seed
from pcbdata.generators.base import Family
from pcbdata.generators.families import family as family_record
from pcbdata.resources import resource_path


def _load(name: str) -> dict:
    with resource_path("presets", name).open("rb") as handle:
        return tomllib.load(handle)


@dataclass(frozen=True)
class D1Preset:
    version: str
    seed: int
    grid_sizes: tuple[int, ...]
    n_nets: int
    placement: str
    connector_version: str
    splits: dict[str, int]


def d1_preset() -> D1Preset:
    data = _load("d1.toml")
    seed = check_seed(data["seed"], "pcbdata/resources/presets/d1.toml seed")
    return D1Preset(version=data["version"], seed=seed,
                    grid_sizes=tuple(data["grid_sizes"]),
                    n_nets=data["n_nets"], placement=data["placement"],
                    connector_version=data["connector_version"], splits=dict(data["splits"]))


@dataclass(frozen=True)
class Level:
    """One level of a family with levels (D2, D2R, ...): its parameters (with `--set`
    overrides applied), version, seed and split sizes from the family's levels file; `tier` is
    the D3 tier a level is calibrated to (D2R), else None."""

    family: str
    name: str
    rank: int
    description: str
    params: Any
    version: str
    seed: int
    splits: dict[str, int]
    overrides: dict
    tier: str | None = None


def _levels_data(family: Family) -> dict:
    if family.levels_file is None:
        raise UserError(f"family {family.name!r} has no levels")
    with family.levels_file.open("rb") as handle:
        return tomllib.load(handle)


def _where(family: Family) -> str:
    path = str(family.levels_file)
    marker = "pcbdata/resources/"
    return marker + path.split(marker, 1)[1] if marker in path else path


def _require_level(levels: dict[str, dict], name: str, family: str) -> None:
    """UserError naming the closest level and every level, unless `name` is one."""
    if name not in levels:
        close = difflib.get_close_matches(name, list(levels), n=1, cutoff=0.3)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        ranked = sorted(levels, key=lambda n: levels[n]["rank"])
        raise UserError(f"unknown {family} level {name!r}{hint} (levels: {', '.join(ranked)})")


def levels(family: str) -> dict[str, dict]:
    """A family's levels as written in its levels file (name -> table)."""
    return dict(_levels_data(family_record(family))["levels"])


def level(family: str, name: str, overrides: dict | None = None) -> Level:
    """A level of a family, with `--set` overrides if any (checked: the preset alone must be
    valid, then with the overrides)."""
    record = family_record(family)
    data = _levels_data(record)
    table = data["levels"]
    _require_level(table, name, record.title.split(":")[0] if ":" in record.title else family)
    entry = table[name]
    spec = {k: v for k, v in entry.items() if k not in record.level_meta}
    where = f"{_where(record)} level {name!r}"
    record.params.from_dict(spec, where)  # type: ignore[attr-defined]
    params = record.params.from_dict(  # type: ignore[attr-defined]
        {**spec, **(overrides or {})}, "--set" if overrides else where)
    return Level(family=family, name=name, rank=entry["rank"],
                 description=entry["description"], params=params,
                 version=entry.get("version", data["version"]),
                 seed=check_seed(data["seed"], f"{_where(record)} seed"),
                 splits=dict(data["splits"]), overrides=dict(overrides or {}),
                 tier=entry.get("tier"))


def parse_overrides(texts: list[str]) -> dict:
    """Every `--set key=value`; a key given twice is an error (the first would be dropped)."""
    out: dict = {}
    for text in texts:
        key, value = parse_override(text)
        if key in out:
            raise UserError(f"--set {key}: given twice ({out[key]!r} and {value!r}); keep one")
        out[key] = value
    return out


def parse_override(text: str) -> tuple[str, object]:
    """`key=value` with a TOML value: numbers, [lists] and {inline = tables}."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key or not value.strip():
        raise UserError(f"--set {text!r}: expected key=value, e.g. --set min_pad_spacing_mm=4.2")
    try:
        return key, tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        raise UserError(f"--set {text!r}: {value.strip()!r} is not a number, [list] or "
                        f"{{table}} (TOML syntax)") from None

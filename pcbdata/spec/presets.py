"""Loads the versioned generator presets (`pcbdata/resources/presets/*.toml`)."""
from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass

from pcbdata.core.errors import UserError
from pcbdata.core.rng import check_seed
from pcbdata.generators.d2 import D2Params
from pcbdata.generators.d2r_params import D2RParams
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
class D2Level:
    name: str
    rank: int
    description: str
    params: D2Params
    version: str
    seed: int
    splits: dict[str, int]
    overrides: dict



def _require_level(levels: dict[str, dict], name: str, family: str) -> None:
    """UserError naming the closest level and every level, unless `name` is one."""
    if name not in levels:
        close = difflib.get_close_matches(name, list(levels), n=1, cutoff=0.3)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        ranked = sorted(levels, key=lambda n: levels[n]["rank"])
        raise UserError(f"unknown {family} level {name!r}{hint} (levels: {', '.join(ranked)})")


def d2_levels() -> dict[str, dict]:
    return dict(_load("d2_levels.toml")["levels"])


def d2_level(name: str, overrides: dict | None = None) -> D2Level:
    data = _load("d2_levels.toml")
    levels = data["levels"]
    _require_level(levels, name, "D2")
    spec = {k: v for k, v in levels[name].items() if k not in ("rank", "description", "version")}
    where = f"pcbdata/resources/presets/d2_levels.toml level {name!r}"
    D2Params.from_dict(spec, where)  # the preset alone must be valid
    merged = {**spec, **(overrides or {})}
    params = D2Params.from_dict(merged, "--set" if overrides else where)
    return D2Level(name=name, rank=levels[name]["rank"], description=levels[name]["description"],
                   params=params, version=levels[name].get("version", data["version"]),
                   seed=check_seed(data["seed"], "pcbdata/resources/presets/d2_levels.toml seed"),
                   splits=dict(data["splits"]), overrides=dict(overrides or {}))


@dataclass(frozen=True)
class D2RLevel:
    name: str
    rank: int
    tier: str
    description: str
    params: D2RParams
    version: str
    seed: int
    splits: dict[str, int]
    overrides: dict


_D2R_FILE = "d2r_levels.toml"
_D2R_META = ("rank", "tier", "description", "version")


def d2r_levels() -> dict[str, dict]:
    return dict(_load(_D2R_FILE)["levels"])


def d2r_level(name: str, overrides: dict | None = None) -> D2RLevel:
    """A realistic level (one per D3 tier), with `--set` overrides if any."""
    data = _load(_D2R_FILE)
    levels = data["levels"]
    _require_level(levels, name, "d2r")
    entry = levels[name]
    spec = {k: v for k, v in entry.items() if k not in _D2R_META}
    where = f"pcbdata/resources/presets/{_D2R_FILE} level {name!r}"
    D2RParams.from_dict(spec, where)  # the preset alone must be valid
    params = D2RParams.from_dict({**spec, **(overrides or {})}, "--set" if overrides else where)
    return D2RLevel(name=name, rank=entry["rank"], tier=entry["tier"],
                    description=entry["description"], params=params,
                    version=entry.get("version", data["version"]),
                    seed=check_seed(data["seed"], f"pcbdata/resources/presets/{_D2R_FILE} seed"),
                    splits=dict(data["splits"]), overrides=dict(overrides or {}))


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

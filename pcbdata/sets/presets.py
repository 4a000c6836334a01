"""Loads the versioned generator presets: D1's (`presets/d1.toml`) and the levels of every
family with levels (its `Family.levels_file`: D2's `presets/d2_levels.toml`, D2R's
`presets/d2r_levels.toml`).

A level whose boards change gets a new major version; the levels file as it was before stays
beside it as `<stem>@<version>.toml` (`d2r_levels@4.0.0.toml`: the levels file when level b
was 4.0.0), so `level(family, name, version=...)` (`pcbdata build d2r --level b
--level-version 4.0.0`) still makes the earlier version's boards, byte for byte, and
`pcbdata verify --release` compares them with that version's pinned release."""
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


#: Marks a kept earlier levels file: `<stem>@<version>.toml`.
VERSION_MARK = "@"


def _levels_data(family: Family) -> dict:
    if family.levels_file is None:
        raise UserError(f"family {family.name!r} has no levels")
    with family.levels_file.open("rb") as handle:
        return tomllib.load(handle)


def _kept_levels_files(family: Family) -> list:
    """The family's earlier levels files (`<stem>@<version>.toml` beside its levels file),
    newest version first."""
    assert family.levels_file is not None
    stem = family.levels_file.name.removesuffix(".toml")
    folder = resource_path("presets")
    kept = [p for p in folder.iterdir()
            if p.name.startswith(stem + VERSION_MARK) and p.name.endswith(".toml")]

    def key(path) -> tuple[int, ...]:
        version = path.name[len(stem) + 1:-len(".toml")]
        return tuple(int(part) if part.isdigit() else -1 for part in version.split("."))

    return sorted(kept, key=key, reverse=True)


def _level_version(data: dict, name: str) -> str | None:
    entry = data["levels"].get(name)
    return None if entry is None else str(entry.get("version", data["version"]))


def level_versions(family: str, name: str) -> list[str]:
    """Every version of a level this package can build: the current one first, then those of
    the kept earlier levels files."""
    record = family_record(family)
    found: list[str] = []
    for data in [_levels_data(record)] + [_load_path(p) for p in _kept_levels_files(record)]:
        version = _level_version(data, name)
        if version is not None and version not in found:
            found.append(version)
    return found


def _load_path(path) -> dict:
    with path.open("rb") as handle:
        return tomllib.load(handle)


def _levels_data_of(record: Family, name: str, version: str | None) -> tuple[dict, str]:
    """The levels file holding level `name` at `version` (None: the current file), and where
    it is (for messages)."""
    data = _levels_data(record)
    if version is None or _level_version(data, name) == version:
        return data, _where(record)
    for path in _kept_levels_files(record):
        kept = _load_path(path)
        if _level_version(kept, name) == version:
            return kept, f"pcbdata/resources/presets/{path.name}"
    known = level_versions(record.name, name)
    raise UserError(f"{record.name} level {name!r} has no version {version!r} in this package "
                    f"(versions: {', '.join(known) or 'none'})")


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


def level(family: str, name: str, overrides: dict | None = None,
          version: str | None = None) -> Level:
    """A level of a family, with `--set` overrides if any (checked: the preset alone must be
    valid, then with the overrides); `version`: an earlier version of the level, from the kept
    levels file that holds it (default: the current one)."""
    record = family_record(family)
    _require_level(_levels_data(record)["levels"], name,
                   getattr(record.params, "LABEL", "") or family)
    data, source = _levels_data_of(record, name, version)
    entry = data["levels"][name]
    spec = {k: v for k, v in entry.items() if k not in record.level_meta}
    where = f"{source} level {name!r}"
    record.params.from_dict(spec, where)  # type: ignore[attr-defined]
    params = record.params.from_dict(  # type: ignore[attr-defined]
        {**spec, **(overrides or {})}, "--set" if overrides else where)
    return Level(family=family, name=name, rank=entry["rank"],
                 description=entry["description"], params=params,
                 version=entry.get("version", data["version"]),
                 seed=check_seed(data["seed"], f"{source} seed"),
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

"""The versioned D3 recipe (`pcbdata/resources/recipes/d3.toml`) as a typed, checked object.

`Recipe` holds one typed table per TOML table (`source`, `engine`, `compat`, `keep`, `tiers`,
`picks`, `published`, `licences`, `overrides`), checked when the file is read: a missing key
or a value of the wrong type is a `UserError` naming the table and key. `data` keeps the
parsed TOML as is: the manifest records it (`parameters`), so its bytes do not depend on this
module. The KiCad workers get the `compat` and `keep` tables as plain dicts (`as_table()`):
policy as data.
"""
from __future__ import annotations

import tomllib
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_bytes
from pcbdata.resources import resource_path

DEFAULT_RECIPE = "d3.toml"
OVERRIDE_KINDS = {"exclude", "exclude_from_test", "replace_pick", "exclude_after_picks"}


def _check(value: Any, kind: type | tuple[type, ...], where: str) -> Any:
    """`value` if it is of `kind` (ints count as floats; bools are neither), else UserError."""
    kinds = kind if isinstance(kind, tuple) else (kind,)
    if float in kinds and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, bool) and bool not in kinds:
        ok = False
    else:
        ok = isinstance(value, kinds)
    if not ok:
        names = " or ".join(k.__name__ for k in kinds)
        raise UserError(f"{where} must be {names}, got {value!r}")
    return value


def _table(cls, data: dict, table: str, origin: str):
    """A typed table from the TOML table `table`: every field checked against its annotation
    (str, int, float, list, dict; `X | None` allows null), absent ones take their default."""
    raw = data.get(table)
    if not isinstance(raw, dict):
        raise UserError(f"{origin}: recipe has no [{table}] table")
    kwargs = {}
    missing = []
    for f in fields(cls):
        if f.name not in raw:
            if f.default is MISSING and f.default_factory is MISSING:  # required
                missing.append(f.name)
            continue
        kwargs[f.name] = _typed(raw[f.name], str(f.type), f"{origin}: [{table}] {f.name}")
    if missing:
        raise UserError(f"{origin}: [{table}] lacks {', '.join(missing)}")
    return cls(**kwargs)


_KINDS: dict[str, type | tuple[type, ...]] = {
    "str": str, "int": int, "float": float, "int | None": int,
    "tuple[str, ...]": list, "dict[str, float]": dict, "dict[str, str]": dict,
}


def _typed(value: Any, annotation: str, where: str) -> Any:
    if annotation.endswith("| None") and value is None:
        return None
    value = _check(value, _KINDS[annotation], where)
    if annotation == "tuple[str, ...]":
        return tuple(_check(v, str, where) for v in value)
    if annotation == "dict[str, float]":  # numbers kept as written: they go into project files
        return {str(k): v for k, v in value.items() if _check(v, float, f"{where}.{k}") == v}
    if annotation == "dict[str, str]":
        return {str(k): _check(v, str, f"{where}.{k}") for k, v in value.items()}
    return value


@dataclass(frozen=True)
class SourceLayout:
    """`[source]`: where the boards are in a PCBench checkout, and its provenance."""

    boards_dir: str
    board_file: str
    routing_file: str
    metadata_file: str
    upstream: str = ""
    commit: str = ""
    github_meta_dir: str = "github_meta"
    licence_file: str = "LICENSE"
    collection_licence: str = "MIT"


@dataclass(frozen=True)
class EngineSettings:
    """`[engine]`: the KiCad version the recipe was made with, per-board UUID seeds, limits."""

    uuid_seed: int
    task_timeout_s: float
    kicad_version: str = ""


@dataclass(frozen=True)
class CompatSettings:
    """`[compat]`: the project-file compatibility pass (SPEC section 3, step 2)."""

    ignore_severities: tuple[str, ...]
    rules: dict[str, float]
    min_hole_to_hole_cap: float
    spacing_probe_mm: float

    def as_table(self) -> dict:
        """Plain data for `pcbdata.kicad.projectfile.patch_project` in KiCad workers."""
        table = asdict(self)
        table["ignore_severities"] = list(self.ignore_severities)
        return table


@dataclass(frozen=True)
class KeepCriteria:
    """`[keep]`: the revalidation rule (SPEC section 3, step 3) and the warning-level checks
    the revalidation DRC may skip. `max_unconnected` None (not set): unconnected items are no
    reason to drop a board."""

    max_errors: int
    max_unconnected: int | None = None
    skip_warning_checks: tuple[str, ...] = ()

    def as_table(self) -> dict:
        """Plain data for `pcbdata.kicad.upgrade.process_board` in KiCad workers."""
        table = asdict(self)
        table["skip_warning_checks"] = list(self.skip_warning_checks)
        return table


@dataclass(frozen=True)
class TierRule:
    """`[tiers]`: D3-A = the first `a_size` rows of the characteristics table; of the rest,
    D3-B = pads <= `b_max_pads`, D3-C = pads > `b_max_pads`."""

    a_size: int
    b_max_pads: int


@dataclass(frozen=True)
class PickRule:
    """`[picks]`: the evaluation subsets of D3-B and D3-C."""

    bins: int
    layers: int | None
    c_trim_fraction: float


@dataclass(frozen=True)
class LicencePolicy:
    """`[licences]`: SPDX ids that permit redistribution; free-text names mapped to SPDX ids."""

    redistributable: tuple[str, ...]
    names: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Override:
    """One `[[overrides]]` entry: an explicit, reasoned departure from the rules."""

    kind: str
    board: str
    reason: str
    config: str | None = None
    replacement: str | None = None

    def as_dict(self) -> dict:
        """The entry as written in the recipe (keys it does not set left out)."""
        return {k: v for k, v in asdict(self).items() if v is not None}


@dataclass(frozen=True)
class Recipe:
    data: dict       # the parsed TOML, as recorded in the manifest
    sha256: str      # of the file's bytes
    origin: str      # file name or path it was read from
    text: bytes
    name: str
    version: str
    source: SourceLayout
    engine: EngineSettings
    compat: CompatSettings
    keep: KeepCriteria
    tiers: TierRule
    picks: PickRule
    licences: LicencePolicy
    all_overrides: tuple[Override, ...] = ()
    #: `[published]`: the published test split of a config, pinned by board name (step 9)
    published: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def overrides(self, kind: str) -> list[Override]:
        return [o for o in self.all_overrides if o.kind == kind]


def _overrides(data: dict, origin: str) -> tuple[Override, ...]:
    out = []
    for entry in data.get("overrides", []):
        if not isinstance(entry, dict) or entry.get("kind") not in OVERRIDE_KINDS:
            kind = entry.get("kind") if isinstance(entry, dict) else entry
            raise UserError(f"{origin}: override kind {kind!r} is not one of "
                            f"{', '.join(sorted(OVERRIDE_KINDS))}")
        if not entry.get("board") or not str(entry.get("reason", "")).strip():
            raise UserError(f"{origin}: every override needs a board and a reason")
        if entry["kind"] == "replace_pick" and not entry.get("replacement"):
            raise UserError(f"{origin}: replace_pick override of {entry['board']} "
                            f"needs a replacement")
        known = {f.name for f in fields(Override)}
        out.append(Override(**{k: str(v) for k, v in entry.items() if k in known}))
    return tuple(out)


def _published(data: dict, origin: str) -> dict[str, tuple[str, ...]]:
    """`[published]`: config name -> the board names of its published test split."""
    raw = data.get("published", {})
    if not isinstance(raw, dict):
        raise UserError(f"{origin}: [published] must be a table of config = [board names]")
    out = {}
    for config, names in sorted(raw.items()):
        where = f"{origin}: [published] {config}"
        names = tuple(_check(n, str, where) for n in _check(names, list, where))
        if len(set(names)) != len(names):
            raise UserError(f"{where} names a board twice")
        out[str(config)] = names
    return out


def parse_recipe(raw: bytes, origin: str) -> Recipe:
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise UserError(f"{origin}: not a valid recipe ({exc})") from None
    head = data.get("recipe")
    if not isinstance(head, dict):
        raise UserError(f"{origin}: recipe has no [recipe] table")
    missing = [k for k in ("name", "version") if k not in head]
    if missing:
        raise UserError(f"{origin}: [recipe] lacks {', '.join(missing)}")
    return Recipe(data=data, sha256=sha256_bytes(raw), origin=origin, text=raw,
                  name=str(head["name"]), version=str(head["version"]),
                  source=_table(SourceLayout, data, "source", origin),
                  engine=_table(EngineSettings, data, "engine", origin),
                  compat=_table(CompatSettings, data, "compat", origin),
                  keep=_table(KeepCriteria, data, "keep", origin),
                  tiers=_table(TierRule, data, "tiers", origin),
                  picks=_table(PickRule, data, "picks", origin),
                  licences=_table(LicencePolicy, data, "licences", origin),
                  all_overrides=_overrides(data, origin),
                  published=_published(data, origin))


def packaged_recipes() -> list[str]:
    """Names of the recipes shipped in the package: `d3` (the current one) and `d3-<version>`
    for each earlier version, so an older set stays rebuildable."""
    return sorted(p.name[:-5] for p in resource_path("recipes").iterdir()
                  if p.name.endswith(".toml"))


def load_recipe(path: str | Path | None = None) -> Recipe:
    """The recipe at `path`, a packaged recipe by name (`d3`, `d3-1.0.0`; see
    `packaged_recipes`), or the packaged default recipe."""
    if path is None:
        raw = resource_path("recipes", DEFAULT_RECIPE).read_bytes()
        return parse_recipe(raw, DEFAULT_RECIPE)
    packaged = resource_path("recipes", f"{path}.toml")
    if str(path) in packaged_recipes() and not Path(path).exists():
        return parse_recipe(packaged.read_bytes(), f"{path}.toml")
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such recipe file (packaged recipes: "
                        f"{', '.join(packaged_recipes())})")
    return parse_recipe(path.read_bytes(), str(path))


def tier_rules(parameters: dict | None) -> tuple[TierRule, PickRule]:
    """The tier and pick rules a D3 manifest entry records (its `parameters` are the recipe it
    was built with), or the packaged recipe's when it records none."""
    try:
        if parameters and "tiers" in parameters and "picks" in parameters:
            return (_table(TierRule, parameters, "tiers", "manifest"),
                    _table(PickRule, parameters, "picks", "manifest"))
    except UserError:
        pass
    recipe = load_recipe()
    return recipe.tiers, recipe.picks

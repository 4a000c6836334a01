"""The registry of board-set configs, kept as data: one `ConfigSpec` per config.

A config is what a user names (`d1-g50`, `d2`, `d2-hard`, `d3-a`): its family, level or grid or
tier, version, seed, split sizes and how its random streams are coupled. This module is the one
place that makes config names and reads them back; the CLI and the build library
(`pcbdata.build`), the golden tests, publication and the routing environment's ids all use
it.

Names: `d1-g<grid>` (`-<placement>` unless uniform), `d2` (the benchmark level), `d2-<level>`,
`d2-<level>-custom-<hash>` (a level with `--set` overrides; hash of the parameters),
`d2r-<level>` and `d2r-<level>-custom-<hash>` (realistic boards, one level per D3 tier),
`d3-<tier>`.

Seed coupling, stated once: every synthetic board draws from its own stream
`SeedSequence(entropy=seed, spawn_key=(family, variant, split, index))` (`pcbdata.core.rng`). D1's
variant is the grid size, so grids are independent. **D2 levels share one stream per board
index** (variant 0 for every level): board i of `d2-hard` starts from the same random numbers as
board i of `d2`. Levels differ through their parameters only, so a level comparison is paired
board by board. Changing that would change every D2 board and needs a major version bump.
"""
from __future__ import annotations

import difflib
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_text
from pcbdata.generators.base import Family
from pcbdata.generators.families import CURATED, families, family, is_family
from pcbdata.model.manifest import MANIFEST_NAME, read_manifest

if TYPE_CHECKING:
    from pcbdata.generators.base import Generator

SYNTHETIC_SPLITS = ("train", "validation", "test")
D3_SPLITS = ("test", "full")
D3_TIERS = {"A": "d3-a", "B": "d3-b", "C": "d3-c"}
D3_COUPLING = "no random draws: boards come from the PCBench snapshot and the recipe"
_D1_NAME = re.compile(r"d1-g(?P<grid>\d+)(?:-(?P<placement>.+))?")


@dataclass(frozen=True)
class ConfigSpec:
    """One config. `parameters` are the generator parameters (D1, D2) or the recipe's tier
    definition (D3); `seed` is None for D3; `sizes` are the default split sizes; `manifest`
    holds the family's extra fields of the manifest's config entry (D1: connector version; D2:
    level, description, overrides)."""

    name: str
    family: str
    version: str
    splits: tuple[str, ...]
    description: str
    seed: int | None = None
    grid: int | None = None
    placement: str | None = None
    level: str | None = None
    rank: int | None = None
    tier: str | None = None
    parameters: dict = field(default_factory=dict, compare=False, hash=False)
    sizes: dict[str, int] = field(default_factory=dict, compare=False, hash=False)
    manifest: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)

    @property
    def seed_coupling(self) -> str:
        return D3_COUPLING if self.family == CURATED else family(self.family).seed_coupling

    @property
    def synthetic(self) -> bool:
        return is_family(self.family)

    def generator(self) -> Generator:
        """The generator of a synthetic config, from its parameters; D3 has none
        (`UserError`)."""
        if not self.synthetic:
            raise UserError(f"config {self.name!r}: D3 boards are curated, not generated "
                            f"(build them with `pcbdata build d3`)")
        return family(self.family).make_generator(self.parameters, self.manifest,
                                                  f"config {self.name}")


def d1_name(grid: int, placement: str = "uniform") -> str:
    return f"d1-g{grid}" + ("" if placement == "uniform" else f"-{placement}")


def level_name(family_name: str, level: str, parameters: dict | None = None) -> str:
    """`<family>-<level>` (the family's name alone for its default level: `d2`); with
    `parameters` (a level with overrides) the hash of the full parameter set is added."""
    record = family(family_name)
    base = record.name if level == record.default_level else f"{record.name}-{level}"
    if parameters is None:
        return base
    digest = sha256_text(json.dumps(parameters, sort_keys=True))
    return f"{base}-custom-{digest[:8]}"


def d1_config(grid: int, placement: str | None = None) -> ConfigSpec:
    """The D1 config of any grid size and placement (default: the preset's)."""
    from pcbdata.generators.d1 import D1Params
    from pcbdata.sets.presets import d1_preset

    preset = d1_preset()
    placement = placement or preset.placement
    params = D1Params(grid=grid, placement=placement, n_nets=preset.n_nets)
    return ConfigSpec(name=d1_name(grid, placement), family="d1", version=preset.version,
                      splits=SYNTHETIC_SPLITS, seed=preset.seed, grid=grid, placement=placement,
                      description=f"D1 grid boards, G = {grid}, {placement} placement",
                      parameters=params.as_dict(), sizes=dict(preset.splits),
                      manifest={"connector_version": preset.connector_version})


def level_config(family_name: str, level: str | None = None,
                 overrides: dict | None = None, version: str | None = None) -> ConfigSpec:
    """The config of a level of a family with levels (`level_config("d2", "hard")`; default:
    the family's default level), with parameters overridden (`--set`) if any; `version`: an
    earlier version of the level (`sets.presets.level`; default: the current one)."""
    from pcbdata.sets.presets import level as preset_level

    record = family(family_name)
    name = level or record.default_level
    if name is None:
        raise UserError(f"family {family_name!r}: name a level")
    lv = preset_level(family_name, name, overrides, version)
    parameters = lv.params.as_dict()
    return ConfigSpec(name=level_name(family_name, lv.name, parameters if lv.overrides else None),
                      family=family_name, version=lv.version, splits=SYNTHETIC_SPLITS,
                      seed=lv.seed, level=lv.name, rank=lv.rank, tier=lv.tier,
                      description=lv.description, parameters=parameters, sizes=dict(lv.splits),
                      manifest={"level": lv.name, "level_description": lv.description,
                                "overrides": lv.overrides})


def _d3_configs() -> list[ConfigSpec]:
    from dataclasses import asdict

    from pcbdata.sets.recipe import load_recipe

    recipe = load_recipe()
    tiers = recipe.tiers
    descriptions = {"A": f"the {tiers.a_size} smallest kept boards",
                    "B": f"the other boards with at most {tiers.b_max_pads} pads",
                    "C": f"the boards with more than {tiers.b_max_pads} pads"}
    return [ConfigSpec(name=config, family="d3", version=recipe.version, splits=D3_SPLITS,
                       tier=tier, description=f"D3-{tier}: {descriptions[tier]}",
                       parameters=asdict(tiers))
            for tier, config in D3_TIERS.items()]


def registry() -> dict[str, ConfigSpec]:
    """Every named config: D1 at the preset's grids (uniform), every level of each family with
    levels (D2, D2R, and any registered one) by rank, D3 tiers."""
    from pcbdata.sets.presets import d1_preset, levels

    specs = [d1_config(grid) for grid in d1_preset().grid_sizes]
    for record in families():
        if record.has_levels:
            table = levels(record.name)
            specs += [level_config(record.name, name)
                      for name in sorted(table, key=lambda n: table[n]["rank"])]
    specs += _d3_configs()
    return {spec.name: spec for spec in specs}


def get_config(name: str) -> ConfigSpec:
    """A config by name: a registered one, or any D1 grid/placement (`d1-g37-random-walk`).
    An unknown name is a `UserError` naming the closest known one."""
    known = registry()
    if name in known:
        return known[name]
    match = _D1_NAME.fullmatch(name)
    if match and int(match.group("grid")) >= 2:
        return d1_config(int(match.group("grid")), match.group("placement") or "uniform")
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.5)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise UserError(f"unknown config {name!r}{hint} (configs: {', '.join(known)})")


def family_of(name: str) -> str | None:
    """The family a config name belongs to (None for a name of no family): D1's grid names,
    `<family>` or `<family>-...` of a family with levels, `d3...`."""
    if _D1_NAME.fullmatch(name):
        return "d1"
    for record in families():
        if record.has_levels and (name == record.name or name.startswith(record.name + "-")):
            return record.name
    if name in D3_TIERS.values() or name.startswith(CURATED):
        return CURATED
    return None


def order_key(name: str) -> tuple:
    """Reading order of configs: families with levels by rank (`d2` first, then its levels by
    name, then D2R's), d1 by grid size, d3 tiers, then anything else; the first config of a
    set is its default."""
    kind = family_of(name)
    if kind == "d1":
        match = _D1_NAME.fullmatch(name)
        assert match is not None
        placement = match.group("placement")
        return (1, int(match.group("grid")), f"-{placement}" if placement else "", name)
    if kind == CURATED:
        return (2, 0, "", name)
    if kind is not None:
        record: Family = family(kind)
        position = [f.name for f in families()].index(kind)
        return (0, 2 * position + (0 if name == record.name else 1), "", name)
    return (3, 0, "", name)


def config_from_manifest(name: str, entry: dict, where: str = "the manifest") -> ConfigSpec:
    """The config a built set records (its manifest's entry for `name`): family, parameters,
    seed, version and split sizes as built, so a set's custom level (`d2-hard-custom-<hash>`)
    or D1 placement is read back from what was built, never from its name."""
    kind = entry.get("family")
    if kind != CURATED and not (isinstance(kind, str) and is_family(kind)):
        raise UserError(f"{where}: config {name!r} has no known family ({kind!r})")
    parameters = dict(entry.get("parameters") or {})
    splits = entry.get("splits") or {}
    grid = parameters.get("grid") if kind == "d1" else None
    if kind == "d1" and (not isinstance(grid, int) or grid < 2):
        raise UserError(f"{where}: D1 config {name!r} records no grid size (parameters.grid)")
    known = {"family", "set_version", "parameters", "seed", "seed_scheme", "splits", "tier"}
    return ConfigSpec(name=name, family=kind, version=str(entry.get("set_version", "")),
                      splits=tuple(splits), description=str(entry.get("level_description", "")),
                      seed=entry.get("seed"), grid=grid,
                      placement=parameters.get("placement") if kind == "d1" else None,
                      level=entry.get("level"), tier=entry.get("tier"), parameters=parameters,
                      sizes={s: int(v.get("count", 0)) for s, v in splits.items()},
                      manifest={k: v for k, v in entry.items() if k not in known})


def resolve_config(name: str, root) -> ConfigSpec:
    """The config `name` as the environment plays it: with a built set (`root`), what the set's
    manifest records for it (any config the set holds: custom D2 levels, D1 placements, D3
    tiers); without one, the registry's (`pcbdata.sets.configs.get_config`). A set without a
    manifest (boards written by hand) serves the registry's configs it has folders for."""
    if root is None:
        return get_config(name)
    root = Path(root)
    manifest = root / MANIFEST_NAME
    if manifest.is_file():
        held = read_manifest(root).get("configs", {})
        if name not in held:
            raise UserError(_not_held(root, name, sorted(held)))
        return config_from_manifest(name, held[name], str(manifest))
    folders = sorted({board.parts[-4] for board in root.glob("*/*/*/board.kicad_pcb")})
    if name not in folders:
        raise UserError(_not_held(root, name, folders))
    try:
        return get_config(name)
    except UserError:
        raise UserError(f"{root}: no {MANIFEST_NAME} records the parameters of config "
                        f"{name!r} (a set built by `pcbdata build` has one)") from None


def _not_held(root: Path, name: str, held: list[str]) -> str:
    close = difflib.get_close_matches(name, held, n=1, cutoff=0.4)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return (f"{root}: the set holds no config {name!r}{hint} (it holds: "
            f"{', '.join(held) or 'none'})")

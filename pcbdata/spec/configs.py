"""The registry of board-set configs, kept as data: one `ConfigSpec` per config.

A config is what a user names (`d1-g50`, `d2`, `d2-hard`, `d3-a`): its family, level or grid or
tier, version, seed, split sizes and how its random streams are coupled. This module is the one
place that makes config names and reads them back; the CLI and the build library
(`pcbdata.builders`), the golden tests, publication and the routing environment's ids all use
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
from typing import TYPE_CHECKING, Any

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_text

if TYPE_CHECKING:
    from pcbdata.generators.base import Generator

SYNTHETIC_SPLITS = ("train", "validation", "test")
D3_SPLITS = ("test", "full")
D3_TIERS = {"A": "d3-a", "B": "d3-b", "C": "d3-c"}
SEED_COUPLING = {
    "d1": "one stream per (grid, split, index); grids independent",
    "d2": "one stream per (split, index) shared by every level (variant 0): levels are paired "
          "board by board",
    "d2r": "one stream per (split, index) shared by every level (variant 0), disjoint from "
           "D2's (family key 3): levels are paired board by board",
    "d3": "no random draws: boards come from the PCBench snapshot and the recipe",
}
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
        return SEED_COUPLING[self.family]

    @property
    def synthetic(self) -> bool:
        return self.family in ("d1", "d2", "d2r")

    def generator(self) -> Generator:
        """The generator of a synthetic config (D1, D2), from its parameters; D3 has none
        (`UserError`)."""
        if self.family == "d1":
            from pcbdata.generators import D1Generator, D1Params

            assert self.grid is not None
            params = D1Params(grid=self.grid, placement=self.parameters["placement"],
                              n_nets=self.parameters["n_nets"])
            return D1Generator(params, connector_version=self.manifest["connector_version"])
        if self.family == "d2":
            from pcbdata.generators import D2Generator, D2Params

            return D2Generator(D2Params.from_dict(self.parameters, f"config {self.name}"))
        if self.family == "d2r":
            from pcbdata.generators import D2RGenerator, D2RParams

            return D2RGenerator(D2RParams.from_dict(self.parameters, f"config {self.name}"))
        raise UserError(f"config {self.name!r}: D3 boards are curated, not generated "
                        f"(build them with `pcbdata build d3`)")


def d1_name(grid: int, placement: str = "uniform") -> str:
    return f"d1-g{grid}" + ("" if placement == "uniform" else f"-{placement}")


def d2_name(level: str, parameters: dict | None = None) -> str:
    """`d2` for the benchmark level, `d2-<level>` otherwise; `parameters` (given when the level
    has overrides) add the hash of the full parameter set."""
    base = "d2" if level == "default" else f"d2-{level}"
    if parameters is None:
        return base
    digest = sha256_text(json.dumps(parameters, sort_keys=True))
    return f"{base}-custom-{digest[:8]}"


def d2r_name(level: str, parameters: dict | None = None) -> str:
    """`d2r-<level>`; with `parameters` (a level with overrides) the hash of the full set."""
    base = f"d2r-{level}"
    if parameters is None:
        return base
    return f"{base}-custom-{sha256_text(json.dumps(parameters, sort_keys=True))[:8]}"


def d1_config(grid: int, placement: str | None = None) -> ConfigSpec:
    """The D1 config of any grid size and placement (default: the preset's)."""
    from pcbdata.generators import D1Params
    from pcbdata.spec.presets import d1_preset

    preset = d1_preset()
    placement = placement or preset.placement
    params = D1Params(grid=grid, placement=placement, n_nets=preset.n_nets)
    return ConfigSpec(name=d1_name(grid, placement), family="d1", version=preset.version,
                      splits=SYNTHETIC_SPLITS, seed=preset.seed, grid=grid, placement=placement,
                      description=f"D1 grid boards, G = {grid}, {placement} placement",
                      parameters=params.as_dict(), sizes=dict(preset.splits),
                      manifest={"connector_version": preset.connector_version})


def d2_config(level: str = "default", overrides: dict | None = None) -> ConfigSpec:
    """The D2 config of a level, with parameters overridden (`--set`) if any."""
    from pcbdata.spec.presets import d2_level

    lv = d2_level(level, overrides)
    parameters = lv.params.as_dict()
    return ConfigSpec(name=d2_name(lv.name, parameters if lv.overrides else None), family="d2",
                      version=lv.version, splits=SYNTHETIC_SPLITS, seed=lv.seed, level=lv.name,
                      rank=lv.rank, description=lv.description, parameters=parameters,
                      sizes=dict(lv.splits),
                      manifest={"level": lv.name, "level_description": lv.description,
                                "overrides": lv.overrides})


def d2r_config(level: str = "b", overrides: dict | None = None) -> ConfigSpec:
    """The realistic config of a level (one per D3 tier), with `--set` overrides if any."""
    from pcbdata.spec.presets import d2r_level

    lv = d2r_level(level, overrides)
    parameters = lv.params.as_dict()
    return ConfigSpec(name=d2r_name(lv.name, parameters if lv.overrides else None),
                      family="d2r", version=lv.version, splits=SYNTHETIC_SPLITS, seed=lv.seed,
                      level=lv.name, rank=lv.rank, tier=lv.tier, description=lv.description,
                      parameters=parameters, sizes=dict(lv.splits),
                      manifest={"level": lv.name, "level_description": lv.description,
                                "overrides": lv.overrides})


def _d3_configs() -> list[ConfigSpec]:
    from dataclasses import asdict

    from pcbdata.spec.recipe import load_recipe

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
    """Every named config: D1 at the preset's grids (uniform), D2 at every level, the realistic
    levels (D2R), D3 tiers."""
    from pcbdata.spec.presets import d1_preset, d2_levels, d2r_levels

    specs = [d1_config(grid) for grid in d1_preset().grid_sizes]
    levels = d2_levels()
    specs += [d2_config(name) for name in sorted(levels, key=lambda n: levels[n]["rank"])]
    realistic = d2r_levels()
    specs += [d2r_config(name)
              for name in sorted(realistic, key=lambda n: realistic[n]["rank"])]
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
    """The family a config name belongs to (None for a name of no family)."""
    if _D1_NAME.fullmatch(name):
        return "d1"
    if name.startswith("d2r-"):
        return "d2r"
    if name == "d2" or name.startswith("d2-"):
        return "d2"
    if name in D3_TIERS.values() or name.startswith("d3"):
        return "d3"
    return None


def order_key(name: str) -> tuple:
    """Reading order of configs: d2 (then its levels by name), d1 by grid size, d3 tiers, then
    anything else; the first config of a set is its default."""
    family = family_of(name)
    if family == "d2":
        return (0, 0 if name == "d2" else 1, "", name)
    if family == "d2r":
        return (0, 2, "", name)
    if family == "d1":
        match = _D1_NAME.fullmatch(name)
        assert match is not None
        placement = match.group("placement")
        return (1, int(match.group("grid")), f"-{placement}" if placement else "", name)
    if family == "d3":
        return (2, 0, "", name)
    return (3, 0, "", name)


def config_from_manifest(name: str, entry: dict, where: str = "the manifest") -> ConfigSpec:
    """The config a built set records (its manifest's entry for `name`): family, parameters,
    seed, version and split sizes as built, so a set's custom level (`d2-hard-custom-<hash>`)
    or D1 placement is read back from what was built, never from its name."""
    family = entry.get("family")
    if family not in SEED_COUPLING:
        raise UserError(f"{where}: config {name!r} has no known family ({family!r})")
    parameters = dict(entry.get("parameters") or {})
    splits = entry.get("splits") or {}
    grid = parameters.get("grid") if family == "d1" else None
    if family == "d1" and (not isinstance(grid, int) or grid < 2):
        raise UserError(f"{where}: D1 config {name!r} records no grid size (parameters.grid)")
    known = {"family", "set_version", "parameters", "seed", "seed_scheme", "splits", "tier"}
    return ConfigSpec(name=name, family=family, version=str(entry.get("set_version", "")),
                      splits=tuple(splits), description=str(entry.get("level_description", "")),
                      seed=entry.get("seed"), grid=grid,
                      placement=parameters.get("placement") if family == "d1" else None,
                      level=entry.get("level"), tier=entry.get("tier"), parameters=parameters,
                      sizes={s: int(v.get("count", 0)) for s, v in splits.items()},
                      manifest={k: v for k, v in entry.items() if k not in known})

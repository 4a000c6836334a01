"""The registry of board-set configs, kept as data: one `ConfigSpec` per published config.

A config is what a user names (`d1-g50`, `d2`, `d2-hard`, `d3-a`): its family, level or grid or
tier, version, seed and how its random streams are coupled. The CLI, the golden tests,
publication and the routing environment's ids all read this one registry.

Seed coupling, stated once: every synthetic board draws from its own stream
`SeedSequence(entropy=seed, spawn_key=(family, variant, split, index))` (`pcbdata.rng`). D1's
variant is the grid size, so grids are independent. **D2 levels share one stream per board
index** (variant 0 for every level): board i of `d2-hard` starts from the same random numbers as
board i of `d2`. Levels differ through their parameters only, so a level comparison is paired
board by board. Changing that would change every D2 board and needs a major version bump.
"""
from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field

from pcbdata.errors import UserError

FAMILIES = ("d1", "d2", "d3")
SYNTHETIC_SPLITS = ("train", "validation", "test")
D3_SPLITS = ("test", "full")
D3_TIERS = {"A": "d3-a", "B": "d3-b", "C": "d3-c"}
SEED_COUPLING = {
    "d1": "one stream per (grid, split, index); grids independent",
    "d2": "one stream per (split, index) shared by every level (variant 0): levels are paired "
          "board by board",
    "d3": "no random draws: boards come from the PCBench snapshot and the recipe",
}
_D1_NAME = re.compile(r"d1-g(?P<grid>\d+)(?:-(?P<placement>random-walk))?")


@dataclass(frozen=True)
class ConfigSpec:
    """One config of the registry. `parameters` are the generator parameters (D1, D2) or the
    recipe's tier definition (D3); `seed` is None for D3."""

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

    @property
    def seed_coupling(self) -> str:
        return SEED_COUPLING[self.family]

    @property
    def synthetic(self) -> bool:
        return self.family in ("d1", "d2")

    def generator(self):
        """The generator of a synthetic config (D1, D2); D3 has none (`UserError`)."""
        if self.family == "d1":
            from pcbdata.generators import D1Generator, D1Params

            return D1Generator(D1Params(grid=self.grid, placement=self.placement,
                                        n_nets=self.parameters["n_nets"]))
        if self.family == "d2":
            from pcbdata.generators import D2Generator
            from pcbdata.presets import d2_level

            return D2Generator(d2_level(self.level).params)
        raise UserError(f"config {self.name!r}: D3 boards are curated, not generated "
                        f"(build them with `pcbdata build d3`)")


def d1_config(grid: int, placement: str = "uniform") -> ConfigSpec:
    """The D1 config of any grid size and placement (the registry lists the preset's grids)."""
    from pcbdata.generators import D1Params
    from pcbdata.presets import d1_preset

    preset = d1_preset()
    params = D1Params(grid=grid, placement=placement, n_nets=preset.n_nets)
    suffix = "" if placement == "uniform" else f"-{placement}"
    return ConfigSpec(name=f"d1-g{grid}{suffix}", family="d1", version=preset.version,
                      splits=SYNTHETIC_SPLITS, seed=preset.seed, grid=grid, placement=placement,
                      description=f"D1 grid boards, G = {grid}, {placement} placement",
                      parameters=params.as_dict())


def _d2_configs() -> list[ConfigSpec]:
    from pcbdata.presets import d2_level, d2_levels

    specs = []
    for name, raw in sorted(d2_levels().items(), key=lambda item: item[1]["rank"]):
        level = d2_level(name)
        specs.append(ConfigSpec(name=level.config_name, family="d2", version=level.version,
                                splits=SYNTHETIC_SPLITS, seed=level.seed, level=name,
                                rank=level.rank, description=level.description,
                                parameters=level.params.as_dict()))
    return specs


def _d3_configs() -> list[ConfigSpec]:
    from pcbdata.curation.recipe import load_recipe

    recipe = load_recipe()
    tiers = recipe.data.get("tiers", {})
    descriptions = {"A": f"the {tiers.get('a_size', 100)} smallest kept boards",
                    "B": f"the other boards with at most {tiers.get('b_max_pads', 100)} pads",
                    "C": f"the boards with more than {tiers.get('b_max_pads', 100)} pads"}
    return [ConfigSpec(name=config, family="d3", version=recipe.version, splits=D3_SPLITS,
                       tier=tier, description=f"D3-{tier}: {descriptions[tier]}",
                       parameters=dict(tiers))
            for tier, config in D3_TIERS.items()]


def registry() -> dict[str, ConfigSpec]:
    """Every named config: D1 at the preset's grids (uniform), D2 at every level, D3 tiers."""
    from pcbdata.presets import d1_preset

    specs = [d1_config(grid) for grid in d1_preset().grid_sizes]
    specs += _d2_configs() + _d3_configs()
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

"""D2: synthetic gridless two-layer boards with multi-pin nets (SPEC section 2), by level.

`FAMILY` is the family's record (`pcbdata.generators.base.Family`); its levels are
`presets/d2_levels.toml` (`d2` is the `default` level, the benchmark's; `d2-<level>` the others).
"""
from __future__ import annotations

from pcbdata.core.rng import SEED_SCHEME
from pcbdata.generators.base import Family
from pcbdata.generators.d2.generator import D2Generator, D2Params
from pcbdata.resources import resource_path


def _generator(parameters: dict, manifest: dict, where: str) -> D2Generator:
    return D2Generator(D2Params.from_dict(parameters, where))


FAMILY = Family(
    name="d2", seed_key=D2Generator.seed_key, params=D2Params, make_generator=_generator,
    capacities={"max_nets": 32, "max_pads": 128, "max_tracks": 1024, "max_vias": 256,
                "max_outline_points": 64, "max_ratsnest": 128},
    title='D2: synthetic gridless boards',
    text=("Two-layer boards of 80-120 mm sides with 4-6 nets of 2-5 pads: 2.4 mm pads, 30 % "
          "through-hole, 70 % SMD rounded rectangles on F.Cu or B.Cu, centres on a 0.6 mm "
          "lattice inside the central 90 % of the board and at least 4.8 mm apart. Clearance "
          "and track width 0.3 mm, vias 1.2/0.6 mm. Other difficulty levels (`d2-<level>`) "
          "change these knobs; each config records its full parameter set."),
    seed_coupling=("one stream per (split, index) shared by every level (variant 0): levels "
                  "are paired board by board"),
    seed_scheme=SEED_SCHEME, rank=0,
    levels_file=resource_path("presets", "d2_levels.toml"), default_level="default")

__all__ = ["FAMILY", "D2Generator", "D2Params"]

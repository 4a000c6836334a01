"""D2R: realistic synthetic boards, one level per D3 tier (SPEC section 2b).

Modules: `params` (the typed parameters), `footprints` (the parametric footprint library),
`parts` (which parts a board gets), `layout` (outlines and placement), `generator` (the
boards). `FAMILY` is the family's record (`pcbdata.generators.base.Family`); its levels are
`presets/d2r_levels.toml` (`d2r-a`, `d2r-b`, `d2r-c`).
"""
from __future__ import annotations

from pcbdata.core.rng import extended_scheme
from pcbdata.generators.base import Family
from pcbdata.generators.d2r.generator import D2RGenerator
from pcbdata.generators.d2r.params import D2RParams
from pcbdata.resources import resource_path


def _generator(parameters: dict, manifest: dict, where: str) -> D2RGenerator:
    return D2RGenerator(D2RParams.from_dict(parameters, where))


FAMILY = Family(
    name="d2r", seed_key=D2RGenerator.seed_key, params=D2RParams, make_generator=_generator,
    capacities={"max_nets": 1024, "max_pads": 4096, "max_tracks": 4096, "max_vias": 1024,
                "max_outline_points": 2048, "max_ratsnest": 2048},
    title='D2R: realistic synthetic boards',
    text=("Boards that look like the real ones of D3, one level per D3 tier (`d2r-a`, "
          "`d2r-b`, `d2r-c`): multi-pad parts from a parametric footprint library (SMD and "
          "through-hole passives, SOT-23, SOIC/TSSOP, DIP, QFN/QFP at 0.4-0.8 mm pitch, 2.54 "
          "mm pin headers, connectors) on both sides, turned in 90-degree steps, courtyards "
          "never overlapping; power nets on many pins, signal nets joining nearby parts, "
          "unconnected pins; a `Power` net class with its own clearance, track and via, held "
          "by the project and by a rule in `board.kicad_dru`; 2 or 4 copper layers; "
          "rectangular, rounded, chamfered, L-shaped and notched outlines with mounting "
          "holes. Component and pad counts follow lognormal draws calibrated to the tier; no "
          "real board is copied. Each config records its full parameter set."),
    seed_coupling=("one stream per (split, index) shared by every level (variant 0), disjoint "
                  "from D2's (family key 3): levels are paired board by board"),
    seed_scheme=extended_scheme("d1=1, d2=2, d2r=3", "0 for d2 and d2r"), rank=0,
    levels_file=resource_path("presets", "d2r_levels.toml"),
    level_meta=("rank", "tier", "description", "version"))

__all__ = ["FAMILY", "D2RGenerator", "D2RParams"]

"""D1: synthetic grid boards, 5 two-pin nets, one routing layer (SPEC section 1).

`FAMILY` is the family's record (`pcbdata.generators.base.Family`); its configs are one per
grid size (`d1-g<grid>`, `-<placement>` unless uniform) from `presets/d1.toml`.
"""
from __future__ import annotations

from pcbdata.core.rng import SEED_SCHEME
from pcbdata.generators.base import Family
from pcbdata.generators.d1.generator import D1Generator, D1Params, GridInstance


def _generator(parameters: dict, manifest: dict, where: str) -> D1Generator:
    params = D1Params(grid=parameters["grid"], placement=parameters["placement"],
                      n_nets=parameters["n_nets"])
    return D1Generator(params, connector_version=manifest.get("connector_version"))


FAMILY = Family(
    name="d1", seed_key=D1Generator.seed_key, params=D1Params, make_generator=_generator,
    capacities={"max_nets": 8, "max_pads": 16, "max_tracks": 512, "max_vias": 16,
                "max_outline_points": 64, "max_ratsnest": 16},
    title='D1: synthetic grid boards',
    text=("Five two-pin nets (NET1..NET5) on a G x G lattice spanning 100 mm (pitch g = "
          "100/G): 10 square SMD pads of side g/2 on F.Cu in 10 distinct cells drawn "
          "uniformly at random, paired in draw order. Clearance = track width = "
          "copper-to-edge clearance = g/2; vias 0.6/0.3 mm. Routing is single-layer: a custom "
          "rule in `board.kicad_dru` forbids tracks and vias on B.Cu, so KiCad's DRC flags "
          "any use of it. The same instances are given as Connector arrays "
          "(`starts`/`targets` cell coordinates, also in `<config>/<split>.npz`) for "
          "grid-action baselines (Jumanji Connector, Mava)."),
    seed_coupling='one stream per (grid, split, index); grids independent',
    seed_scheme=SEED_SCHEME, rank=1)

__all__ = ["FAMILY", "D1Generator", "D1Params", "GridInstance"]

"""D3 curation: rebuild the curated real-board set from a PCBench checkout (SPEC section 3).

Modules, one job each:
- `recipe`: the versioned recipe (`pcbdata/resources/recipes/d3.toml`), typed and checked, with its
  version and sha256;
- `corpus`: scan a checkout (hashes, `final.json` counts, fates known without KiCad);
- `picks`: characteristics order, tiers, evaluation picks (pure functions);
- `attribution`: source repository, author, licence (SPDX) per board;
- `build`: orchestration with per-board state, resume, outputs and the manifest.
The KiCad side (upgrade, DRC, bare board) is `pcbdata.kicad.upgrade`, run in KiCad workers;
the project-file compatibility pass (pure JSON) is `pcbdata.kicad.projectfile`. Both receive
the recipe's tables as plain data.
"""

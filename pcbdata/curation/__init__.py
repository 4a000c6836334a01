"""D3 curation: the rules that make the curated real-board set from a PCBench checkout (SPEC
section 3); the build that applies them is `pcbdata.build.d3`.

Modules, one job each:
- `corpus`: scan a checkout (hashes, `final.json` counts, fates known without KiCad);
- `picks`: characteristics order, tiers, evaluation picks (pure functions);
- `attribution`: source repository, author, licence (SPDX) per board;
The KiCad side (upgrade, DRC, bare board) is `pcbdata.kicad.upgrade`, run in KiCad workers;
the project-file compatibility pass (pure JSON) is `pcbdata.kicad.projectfile`. Both receive
the recipe's tables as plain data.
"""

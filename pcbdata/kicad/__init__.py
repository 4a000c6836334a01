"""Access to KiCad 9 (pcbnew, kicad-cli): the only package that runs KiCad, and the bottom layer.

Every KiCad call runs inside `KicadPool` worker processes (`pool.py`, started by exec of
`worker.py`): `basics.py` (pcbnew:
load, DRC, staging), `upgrade.py` (D3), `scoring.py` (evaluator), `specctra.py` (routing),
`cli_tools.py` (kicad-cli), `board_records.py` (a board as drawing records). Pure helpers:
`drc_report.py` (the DRC report as plain data), `projectfile.py` (`.kicad_pro` JSON). Modules
here import only the standard library, `pcbnew`, each other and pcbdata's leaf modules
(`tests/kicad/test_layering.py`); policy (recipe tables, rules) arrives as plain data.
"""
from __future__ import annotations

import functools

from pcbdata.kicad.drc_report import DrcReport, Violation, parse_drc_report
from pcbdata.kicad.pool import KicadError, KicadPool, Outcome

__all__ = ["DrcReport", "Violation", "parse_drc_report", "KicadError", "KicadPool",
           "Outcome", "kicad_version"]


@functools.lru_cache(maxsize=1)
def kicad_version() -> str:
    """The version of KiCad's pcbnew module, asked in a worker so a broken install can't crash
    us; `KicadError` when KiCad cannot be started."""
    with KicadPool(workers=1, task_timeout=60) as pool:
        return pool.call("pcbdata.kicad.basics:kicad_version")

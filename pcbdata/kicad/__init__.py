"""Access to KiCad 9 (pcbnew, kicad-cli). The only package that runs KiCad.

`kicad.py` holds the code that imports `pcbnew` (run only inside workers), `pool.py` the
isolated worker processes (started by exec of `worker.py`), `drc_report.py` the plain-data DRC
report.
"""
from __future__ import annotations

import functools
import shutil
import subprocess

from pcbdata.kicad.drc_report import DrcReport, Violation, parse_drc_report
from pcbdata.kicad.pool import KicadError, KicadPool, Outcome

REQUIRED_KICAD_VERSION = "9.0.8"

__all__ = ["DrcReport", "Violation", "parse_drc_report", "KicadError", "KicadPool",
           "Outcome", "kicad_version", "kicad_cli", "REQUIRED_KICAD_VERSION"]


@functools.lru_cache(maxsize=1)
def kicad_version() -> str:
    """The version of KiCad's pcbnew module, asked in a worker so a broken install can't crash us."""
    with KicadPool(workers=1, task_timeout=60) as pool:
        return pool.call("pcbdata.kicad.basics:kicad_version")


def kicad_cli() -> str:
    path = shutil.which("kicad-cli")
    if path is None:
        raise KicadError("kicad-cli not found on PATH; run scripts/install-kicad.sh")
    return path


def kicad_cli_drc(board_path: str, report_path: str, timeout: float = 300) -> None:
    """One `kicad-cli pcb drc` call: the per-board baseline the benchmarks compare against."""
    subprocess.run(
        [kicad_cli(), "pcb", "drc", "--all-track-errors", "--format", "json",
         "--output", report_path, board_path],
        check=True, capture_output=True, timeout=timeout,
    )

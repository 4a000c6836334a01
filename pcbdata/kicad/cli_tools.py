"""`kicad-cli` calls. Like every KiCad call of pcbdata they run inside `KicadPool` workers
(`pool.map("pcbdata.kicad.cli_tools:kicad_cli_drc", ...)`), never in the caller's process."""
from __future__ import annotations

import shutil
import subprocess


def kicad_cli() -> str:
    """The path of `kicad-cli`; FileNotFoundError (with the remedy) when it is not installed."""
    path = shutil.which("kicad-cli")
    if path is None:
        raise FileNotFoundError("kicad-cli not found on PATH; run scripts/install-kicad.sh")
    return path


def kicad_cli_drc(board_path: str, report_path: str, timeout: float = 300) -> None:
    """One `kicad-cli pcb drc` call (JSON report): the per-board baseline the benchmarks
    compare pcbdata's in-process DRC against."""
    subprocess.run(
        [kicad_cli(), "pcb", "drc", "--all-track-errors", "--format", "json",
         "--output", report_path, board_path],
        check=True, capture_output=True, timeout=timeout,
    )

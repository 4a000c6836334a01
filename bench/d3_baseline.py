"""The obvious D3 pipeline, for the benchmark only: per board, a pcbnew load-and-save in a
fresh Python process, the project compatibility pass, then one `kicad-cli pcb drc`; two boards
at a time. Prints one JSON line per board (name, kept, seconds)."""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

UPGRADE = """
import sys, pcbnew
board = pcbnew.LoadBoard(sys.argv[1])
sys.exit(0 if board is not None and pcbnew.SaveBoard(sys.argv[2], board) else 1)
"""


def one(folder: Path, compat: dict) -> dict:
    from pcbdata.kicad.drc_report import parse_drc_report
    from pcbdata.kicad.projectfile import default_clearance, dumps_project, patch_project

    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="d3-baseline-") as tmp:
        board = os.path.join(tmp, "board.kicad_pcb")
        up = subprocess.run([sys.executable, "-c", UPGRADE, str(folder / "processed.kicad_pcb"),
                             board], capture_output=True, timeout=300)
        if up.returncode != 0:
            return {"name": folder.name, "kept": False, "seconds": time.perf_counter() - start}
        project_path = os.path.join(tmp, "board.kicad_pro")
        with open(project_path, encoding="utf-8") as handle:
            project = json.load(handle)
        spacing = None if default_clearance(project) else float(compat["spacing_probe_mm"])
        with open(project_path, "w", encoding="utf-8") as handle:
            handle.write(dumps_project(patch_project(project, compat, spacing)))
        report = os.path.join(tmp, "drc.rpt")
        subprocess.run(["kicad-cli", "pcb", "drc", "--severity-all", "--all-track-errors",
                        "--format", "report", "-o", report, board], capture_output=True,
                       timeout=300)
        try:
            parsed = parse_drc_report(Path(report).read_text(encoding="utf-8", errors="replace"))
        except (OSError, ValueError):
            return {"name": folder.name, "kept": False, "seconds": time.perf_counter() - start}
        errors = sum(1 for v in parsed.violations
                     if v.section != "unconnected" and v.severity == "error")
        unconnected = sum(1 for v in parsed.violations
                          if v.section == "unconnected" and v.severity != "excluded")
        return {"name": folder.name, "kept": errors == 0 and unconnected == 0,
                "seconds": time.perf_counter() - start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--source", required=True)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    from pcbdata.sets.recipe import load_recipe

    compat = load_recipe()["compat"]
    folders = sorted(p for p in (Path(args.source) / "PCBs").iterdir()
                     if (p / "processed.kicad_pcb").is_file())
    with ThreadPoolExecutor(args.workers) as pool:
        for result in pool.map(lambda f: one(f, compat), folders):
            print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()

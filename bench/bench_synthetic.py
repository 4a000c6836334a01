"""Benchmarks for the synthetic sets. Run: .venv/bin/python bench/bench_synthetic.py

1. Write the full default D2 (10 256 boards) without KiCad checks (target <= 30 s).
2. Write D1 at G=500 (10 256 boards) without KiCad checks (target <= 30 s).
3. KiCad check throughput on the same 128 D2 test boards: pcbdata's in-process DRC in
   long-lived workers vs one `kicad-cli pcb drc` per board, both with 2 at a time; the
   violation counts must agree (target >= 10x).
4. Peak memory of a full default D2 build with its KiCad checks, whole process tree (< 1 GB).
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import machine, run_measured  # noqa: E402

PCBDATA = [sys.executable, "-m", "pcbdata"]


def kicad_cli_counts(report_path: Path) -> tuple[int, int]:
    data = json.loads(report_path.read_text())
    other = [v for v in data.get("violations", []) if v.get("severity") != "exclusion"]
    return len(other), len(data.get("unconnected_items", []))


def main() -> None:
    from pcbdata.kicad import DrcReport, KicadPool
    from pcbdata.kicad.cli_tools import kicad_cli_drc

    results = {"machine": machine()}
    with tempfile.TemporaryDirectory(prefix="pcbdata-bench-") as tmp:
        tmp = Path(tmp)
        d2 = run_measured([*PCBDATA, "build", "d2", "--no-check", "--out", str(tmp / "d2")])
        results["write_d2_full_s"] = d2["seconds"]
        results["write_d2_full_peak_mib"] = d2["peak_mib"]
        d1 = run_measured([*PCBDATA, "build", "d1", "--grid", "500", "--no-check",
                           "--out", str(tmp / "d1")])
        results["write_d1_g500_full_s"] = d1["seconds"]

        boards = sorted((tmp / "d2" / "d2" / "test").glob("board_*/board.kicad_pcb"))
        assert len(boards) == 128
        start = time.perf_counter()
        with KicadPool(workers=2) as pool:
            ours = {o.index: DrcReport.from_dict(o.value)
                    for o in pool.map("pcbdata.kicad.basics:drc", [(str(b),) for b in boards])}
        results["check_128_pcbdata_s"] = time.perf_counter() - start

        start = time.perf_counter()

        def baseline(index: int) -> tuple[int, int]:
            report = tmp / f"cli-{index}.json"
            kicad_cli_drc(str(boards[index]), str(report))
            return kicad_cli_counts(report)

        with ThreadPoolExecutor(max_workers=2) as threads:
            theirs = list(threads.map(baseline, range(len(boards))))
        results["check_128_kicad_cli_s"] = time.perf_counter() - start
        mismatches = [i for i in range(len(boards))
                      if (len([v for v in ours[i].violations if v.section != "unconnected"]),
                          len(ours[i].unconnected)) != theirs[i]]
        results["check_counts_identical"] = not mismatches
        results["check_speedup"] = results["check_128_kicad_cli_s"] / results["check_128_pcbdata_s"]

        full = run_measured([*PCBDATA, "build", "d2", "--out", str(tmp / "d2-checked")])
        results["build_d2_full_checked_s"] = full["seconds"]
        results["build_d2_full_checked_peak_mib"] = full["peak_mib"]

    out = Path(__file__).parent / "runs" / "synthetic.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(results, indent=1) + "\n")
    print(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()

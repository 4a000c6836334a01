"""D3 build benchmark: the obvious pipeline (fresh-process pcbnew load-and-save + one
`kicad-cli pcb drc` per board, two at a time; bench/d3_baseline.py) against
`pcbdata build d3` (long-lived recycled KiCad workers, in-process DRC, two workers), on the
same sample of boards in one run. Wall time and peak memory of each whole process tree.

    .venv/bin/python bench/bench_d3.py [--source PCBENCH_DIR] [--sample 100]

Without --source the shared snapshot (../shared/pcbench/pcbench.tar.xz) is unpacked to a
temporary folder. Results: bench/runs/d3.json.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from _measure import machine, run_measured  # noqa: E402

SNAPSHOT = REPO.parent / "shared" / "pcbench" / "pcbench.tar.xz"


def sample_checkout(source: Path, dest: Path, size: int) -> list[str]:
    """A checkout of `size` boards spread evenly over the name order (symlinked)."""
    boards = sorted(p.name for p in (source / "PCBs").iterdir()
                    if (p / "processed.kicad_pcb").is_file())
    step = len(boards) / size
    names = [boards[int(i * step)] for i in range(size)]
    (dest / "PCBs").mkdir(parents=True)
    for name in names:
        (dest / "PCBs" / name).symlink_to(source / "PCBs" / name, target_is_directory=True)
    for extra in ("github_meta", "LICENSE"):
        if (source / extra).exists():
            (dest / extra).symlink_to(source / extra)
    return names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--source", type=Path, default=None)
    parser.add_argument("--sample", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--results", type=Path, default=HERE / "runs" / "d3.json")
    args = parser.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-d3-"))
    try:
        source = args.source
        if source is None:
            (tmp / "pcbench").mkdir()
            subprocess.run(["tar", "-xJf", str(SNAPSHOT), "-C", str(tmp / "pcbench")],
                           check=True)
            source = tmp / "pcbench"
        names = sample_checkout(source, tmp / "sample", args.sample)
        python = sys.executable
        base = run_measured([python, str(HERE / "d3_baseline.py"), "--source",
                             str(tmp / "sample"), "--workers", str(args.workers)], cwd=REPO)
        ours = run_measured([python, "-m", "pcbdata", "build", "d3", "--quiet", "--source",
                             str(tmp / "sample"), "--out", str(tmp / "out"), "--workers",
                             str(args.workers)], cwd=REPO)
        base_kept = sorted(json.loads(line)["name"] for line in base["stdout"].splitlines()
                           if json.loads(line)["kept"])
        report = json.loads((tmp / "out" / "curation_report.json").read_text())
        ours_kept = sorted(b["name"] for b in report["boards"] if b["fate"] == "kept")
        result = {
            "machine": machine(), "boards": len(names), "workers": args.workers,
            "baseline": {"seconds": round(base["seconds"], 1),
                         "peak_mib": round(base["peak_mib"]), "kept": len(base_kept)},
            "pcbdata": {"seconds": round(ours["seconds"], 1),
                        "peak_mib": round(ours["peak_mib"]), "kept": len(ours_kept)},
            "speedup": round(base["seconds"] / ours["seconds"], 2),
            "kept_sets_equal": base_kept == ours_kept,
            "kept_only_baseline": sorted(set(base_kept) - set(ours_kept)),
            "kept_only_pcbdata": sorted(set(ours_kept) - set(base_kept)),
        }
        args.results.parent.mkdir(parents=True, exist_ok=True)
        args.results.write_text(json.dumps(result, indent=1) + "\n")
        print(json.dumps(result, indent=1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()

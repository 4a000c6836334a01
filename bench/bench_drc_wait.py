"""Benchmark: KiCad DRC with and without the DRC-wait preload (`pcbdata.kicad.fastwait`).

Checks every board twice, in 2-worker pools started without and with the preload, and compares
the violations (`fastwait.canonical_violations`; a board that differs is re-checked to tell
KiCad's own run-to-run variation from a change made by the preload, see
`tests.helpers.drc_parity`). Board groups:

- the 128 D2 test boards with straight pad-to-pad tracks (many shorts and clearance errors),
- the same 128 routed by freeroute (`pcbdata route`), checked under their instance's rules,
- real D3 boards (PCBench snapshot `processed.kicad_pcb`, spread over file sizes);

then runs `pcbdata build d3` on a sample of the snapshot without and with the preload (the
preload inherited by its workers) and compares the two outputs file by file (per-board timings
excepted).

    .venv/bin/python bench/bench_drc_wait.py [--work DIR] [--runs RUNS --set SET] [--d3 24]
        [--d3-build 100]

Without --runs the D2 set is built and routed in --work (freeroute, about 4 min on 2 cores).
Writes bench/runs/drc_wait.json.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path[:0] = [str(HERE), str(ROOT)]

from _measure import machine  # noqa: E402

from pcbdata.kicad import fastwait  # noqa: E402
from pcbdata.testing.drc import drc_parity, with_straight_tracks  # noqa: E402
from pcbdata.testing.sets import write_board  # noqa: E402

SNAPSHOT = ROOT.parent / "shared" / "pcbench" / "pcbench.tar.xz"


def cli(*args: str) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "pcbdata", *args], env=env, capture_output=True,
                          text=True)
    if done.returncode != 0:
        raise RuntimeError(f"pcbdata {' '.join(args)} failed:\n{done.stderr[-2000:]}")


def tracked_d2(work: Path) -> list[str]:
    from pcbdata.generators.d2 import D2Generator
    from pcbdata.sets.presets import level

    level = level("d2", "default")
    generator = D2Generator(level.params)
    return [str(write_board(work / "tracked" / f"board_{i:05d}",
                            with_straight_tracks(generator.generate(level.seed, "test", i).board)))
            for i in range(level.splits["test"])]


def routed_d2(work: Path, set_dir: Path | None, runs: Path | None) -> list[tuple[str, str]]:
    if runs is None:
        set_dir, runs = work / "set", work / "runs"
        if not (set_dir / "manifest.json").is_file():
            cli("build", "d2", "--splits", "test", "--no-check", "--out", str(set_dir))
        cli("route", str(set_dir), "--config", "d2", "--split", "test", "--out", str(runs))
    pairs = []
    for board in sorted(runs.glob("*/0.kicad_pcb")):
        project = set_dir / "d2" / "test" / board.parent.name / "board.kicad_pro"
        pairs.append((str(board), str(project)))
    return pairs


def real_d3(work: Path, count: int) -> list[str]:
    if not SNAPSHOT.is_file():
        print(f"no PCBench snapshot at {SNAPSHOT}: D3 boards skipped", file=sys.stderr)
        return []
    folder = work / "pcbench"
    if not (folder / "PCBs").is_dir():
        folder.mkdir(parents=True, exist_ok=True)
        subprocess.run(["tar", "-xJf", str(SNAPSHOT), "-C", str(folder)], check=True)
    boards = sorted((p for p in (folder / "PCBs").glob("*/processed.kicad_pcb")
                     if "(segment" in p.read_text(errors="replace")),
                    key=lambda p: (p.stat().st_size, p.parent.name))
    step = max(1, len(boards) // count)
    return [str(p) for p in boards[::step][:count]]


def _without_timings(value):
    if isinstance(value, dict):
        return {k: _without_timings(v) for k, v in value.items() if k not in ("seconds", "timings")}
    if isinstance(value, list):
        return [_without_timings(v) for v in value]
    return value


def _same_outputs(a: Path, b: Path) -> list[str]:
    """Files that differ between two D3 build outputs, ignoring the recorded timings
    (`.d3-state/`, the last column of curation_report.csv, seconds/timings in JSON)."""
    differ = []
    files = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    files |= {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    for rel in sorted(files):
        if rel.parts[0] == ".d3-state":
            continue
        x, y = a / rel, b / rel
        if not (x.is_file() and y.is_file()):
            differ.append(str(rel))
        elif rel.name == "curation_report.json":
            if (_without_timings(json.loads(x.read_text()))
                    != _without_timings(json.loads(y.read_text()))):
                differ.append(str(rel))
        elif rel.name == "curation_report.csv":
            strip = lambda t: [line.rsplit(",", 1)[0] for line in t.splitlines()]  # noqa: E731
            if strip(x.read_text()) != strip(y.read_text()):
                differ.append(str(rel))
        elif x.read_bytes() != y.read_bytes():
            differ.append(str(rel))
    return differ


def d3_build(work: Path, count: int) -> dict | None:
    from bench_d3 import sample_checkout

    if count <= 0 or not (work / "pcbench" / "PCBs").is_dir():
        return None
    sample = work / f"d3-sample-{count}"
    if not sample.is_dir():
        sample_checkout(work / "pcbench", sample, count)
    figures = {"boards": count}
    for mode, enabled in (("without", False), ("with", True)):
        out = work / f"d3-build-{mode}"
        if out.exists():
            subprocess.run(["rm", "-rf", str(out)], check=True)
        env = {**os.environ, "PYTHONPATH": str(ROOT), **fastwait.preload_env(enabled)}
        start = time.monotonic()
        done = subprocess.run([sys.executable, "-m", "pcbdata", "build", "d3", "--source",
                               str(sample), "--out", str(out), "--workers", "2", "--quiet"],
                              env=env, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"pcbdata build d3 ({mode} the preload) failed:\n"
                               f"{done.stderr[-2000:]}")
        figures[f"wall_s_{mode}"] = time.monotonic() - start
        figures[f"drc_s_{mode}"] = sum(json.loads(p.read_text()).get("timings", {}).get("drc", 0)
                                       for p in (out / ".d3-state").glob("*.json"))
    figures["differing_files"] = _same_outputs(work / "d3-build-without", work / "d3-build-with")
    return figures


def summarise(name: str, paths: list, result: dict) -> dict:
    slow = [r["seconds"] for r in result["slow"]]
    fast = [r["seconds"] for r in result["fast"]]
    label = lambda p: Path(p if isinstance(p, str) else p[0]).parent.name  # noqa: E731
    return {"group": name, "boards": len(paths), "identical": result["identical"],
            "kicad_varies": [label(p) for p in result["kicad_varies"]],
            "different": [label(p) for p in result["different"]],
            "median_s_without": statistics.median(slow), "median_s_with": statistics.median(fast),
            "total_s_without": sum(slow), "total_s_with": sum(fast),
            "speedup_total": sum(slow) / sum(fast),
            "sleeps_cut": sum(r["shortened"] for r in result["fast"])}


def print_table(rows: list[dict]) -> None:
    print(f"{'group':28s} {'boards':>6s} {'parity':>20s} {'median s':>17s} "
          f"{'sum s':>15s} {'x':>5s}")
    for r in rows:
        parity = f"{r['identical']} same, {len(r['kicad_varies'])} var, {len(r['different'])} diff"
        print(f"{r['group']:28s} {r['boards']:6d} {parity:>20s} "
              f"{r['median_s_without']:7.3f} -> {r['median_s_with']:6.3f} "
              f"{r['total_s_without']:6.1f} -> {r['total_s_with']:5.1f} {r['speedup_total']:5.1f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--work", type=Path, default=None, help="work folder (default: temporary)")
    parser.add_argument("--set", type=Path, default=None, help="built D2 set that --runs routed")
    parser.add_argument("--runs", type=Path, default=None, help="pcbdata route output (rollout 0)")
    parser.add_argument("--d3", type=int, default=24, help="real D3 boards (default 24)")
    parser.add_argument("--d3-build", type=int, default=100,
                        help="boards of the D3 build comparison (default 100; 0: skip)")
    parser.add_argument("--json", type=Path, default=ROOT / "bench" / "runs" / "drc_wait.json")
    args = parser.parse_args()
    if fastwait.library_path() is None:
        print("the preload is not built: run scripts/build-fastwait.sh", file=sys.stderr)
        return 2
    if (args.runs is None) != (args.set is None):
        parser.error("--runs and --set go together")
    work = args.work or Path(tempfile.mkdtemp(prefix="bench-drc-wait-"))
    load_before = os.getloadavg()
    started = datetime.now(UTC)
    groups = [("D2 test, straight tracks", tracked_d2(work)),
              ("D2 test, freeroute-routed", routed_d2(work, args.set, args.runs)),
              ("D3 real boards", real_d3(work, args.d3))]
    rows = []
    for name, paths in groups:
        if paths:
            start = time.monotonic()
            rows.append(summarise(name, paths, drc_parity(paths)))
            print(f"{name}: {time.monotonic() - start:.0f} s", file=sys.stderr)
    print_table(rows)
    build = d3_build(work, args.d3_build)
    if build:
        print(f"pcbdata build d3, {build['boards']} boards, 2 workers: wall "
              f"{build['wall_s_without']:.1f} -> {build['wall_s_with']:.1f} s, "
              f"DRC (sum over boards) "
              f"{build['drc_s_without']:.1f} -> {build['drc_s_with']:.1f} s, outputs "
              + ("identical" if not build["differing_files"]
                 else f"DIFFER: {build['differing_files']}"))
    results = {"machine": machine(), "started_utc": started.strftime("%Y-%m-%d %H:%M"),
               "load_average_before": load_before, "load_average_after": os.getloadavg(),
               "workers": 2, "groups": rows, "d3_build": build}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
    changed = any(r["different"] for r in rows) or (build and build["differing_files"])
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())

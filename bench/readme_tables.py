"""Regenerates the README's and docs/evaluator.md's baseline tables end to end.

Builds what it needs into WORK (default /work/tables-work; never into the repository):
the D2 test split (`pcbdata build d2 --splits test`) and D3 from the PCBench snapshot
(unpacked into WORK, then `pcbdata build d3`); routes with `pcbdata route` (freeroute, 5
rollouts; kicad-tools @1 on a stated sample); scores with `pcbdata eval` at k=1 and k=5 (and
`--reference` for D3), and prints the Markdown rows with both counts (CP, DRV: evaluation
count; CP+, DRV+: strict count). Every step resumes: builds skip what is on disk, `route` skips
rollouts with a JSON, `eval` reuses its `scores.jsonl`.

`--prefix` also routes @1 with the freeroute round trip without fixes 3 and 4 of docs/evaluator.md
(no via planning, no boundary inset; rollout 0's engine options are unchanged), to compare.

    nice -n 5 python bench/readme_tables.py --workers 2 [--only d2,d3-a,d3-b] [--prefix]
        [--kicad-tools 16]
    nice -n 5 python bench/readme_tables.py --workers 2 --levels 64   # the calibration table
        [--level-rollouts 1]
    python bench/readme_tables.py --explain d3-a   # freeroute @1 violations by type and pad

Run from the repository root with the venv's Python (KiCad 9.0.8 pcbnew, freeroute,
kicad-tools); it calls `python -m pcbdata` with PYTHONPATH set to the repository.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SNAPSHOT = Path("/work/shared/pcbench/pcbench.tar.xz")
SETS = {"d2": ("D2 test", "d2"), "d3-a": ("D3-A test", "d3"), "d3-b": ("D3-B test", "d3")}
COLUMNS = ("CP (%)", "Pot.", "Rout.", "DRV", "WL (mm)", "Via", "Time (s)", "CP+ (%)", "DRV+")


def pcbdata(*args: str) -> None:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    command = [sys.executable, "-m", "pcbdata", *args]
    print("$ pcbdata " + " ".join(args), file=sys.stderr, flush=True)
    subprocess.run(command, env=env, check=True)


def build(work: Path, family: str, workers: int) -> Path:
    out = work / family
    if (out / "manifest.json").is_file():
        return out
    if family == "d2":
        pcbdata("build", "d2", "--splits", "test", "--out", str(out), "--workers", str(workers))
        return out
    source = work / "pcbench"
    if not (source / "PCBs").is_dir():
        with tarfile.open(SNAPSHOT) as archive:
            archive.extractall(source, filter="data")
    pcbdata("build", "d3", "--source", str(source), "--out", str(out), "--workers",
            str(workers), "--quiet")
    return out


def route(root: Path, config: str, runs: Path, workers: int, rollouts: int,
          router: str = "freeroute", limit: int | None = None) -> None:
    args = ["route", str(root), "--config", config, "--split", "test", "--out", str(runs),
            "--rollouts", str(rollouts), "--workers", str(workers), "--router", router]
    pcbdata(*args, *(["--limit", str(limit)] if limit else []))


def route_prefix(root: Path, config: str, runs: Path, workers: int) -> None:
    """@1 as before the fixes: the same rollout-0 engine options, without via planning and
    boundary inset (`plan_for_vias=False`); resolution and back-side fixes kept as they were."""
    sys.path.insert(0, str(REPO))
    from pcbdata.baselines import route, specctra

    def old_plans(router, router_cmd, rollouts, router_timeout):
        argv, _, label = specctra.router_command("freeroute", None, 0)
        return [route.RolloutPlan(specctra.ROUTE, (argv, router_timeout, True, True, False),
                                    label + " (pre-fix: no via planning, no inset)",
                                    specctra.freeroute_version())]

    route.rollout_plans = old_plans
    route.route_set(root, config, "test", runs, rollouts=1, workers=workers)


def evaluate(root: Path, config: str, report: Path, k: int, runs: Path | None,
             name: str, limit: int | None = None) -> dict:
    if not (report / "summary.json").is_file() or _stale(report, runs):
        args = ["eval", str(root), "--config", config, "--split", "test", "--out", str(report),
                "--k", str(k), "--name", name, "--workers", "4"]
        args += ["--runs", str(runs)] if runs else ["--reference"]
        pcbdata(*args, *(["--limit", str(limit)] if limit else []))
    return json.loads((report / "summary.json").read_text(encoding="utf-8"))


def _stale(report: Path, runs: Path | None) -> bool:
    if runs is None:
        return False
    summary = report / "summary.json"
    newest = max((p.stat().st_mtime for p in runs.rglob("*.json")), default=0.0)
    return newest > summary.stat().st_mtime


def _pct(value) -> str:
    return "-" if value is None else f"{100 * value:.1f}" if value <= 1 else f"{value:.1f}"


def row(label: str, method: str, s: dict) -> str:
    time_s = s.get("time")
    cells = [_pct(s["cp"]), f"{s['pot']:.2f}", f"{s['rout']:.3f}", f"{s['drv']:.2f}",
             f"{s['wl']:.1f}", f"{s['via']:.2f}", "-" if time_s is None else f"{time_s:.2f}",
             _pct(s.get("cp_strict")), f"{s.get('drv_strict', float('nan')):.2f}"]
    return f"| {label} ({s['n_boards']}) | {method} | " + " | ".join(cells) + " |"


# Runs in a separate Python with pcbnew: maps the items of a kicad-cli JSON DRC report to their
# pads and footprints. argv: board, report; prints one JSON object per counted violation.
_ITEMS = r"""
import json, sys, pcbnew
board = pcbnew.LoadBoard(sys.argv[1])
SHAPES = {0: "circle", 1: "rect", 2: "oval", 3: "trapezoid", 4: "roundrect", 5: "chamfered",
          6: "custom"}
pads = {}
for fp in board.GetFootprints():
    for pad in fp.Pads():
        pads[pad.m_Uuid.AsString()] = (fp, pad)
report = json.load(open(sys.argv[2]))
for v in report.get("violations", []):
    if v.get("severity") != "error":
        continue
    found = []
    for item in v.get("items", []):
        hit = pads.get(item.get("uuid"))
        if hit is None:
            found.append({"item": item.get("description", "").split(" ")[0]})
            continue
        fp, pad = hit
        shape = pad.GetShape(pcbnew.F_Cu)
        found.append({"item": "pad", "footprint": str(fp.GetFPID().GetUniStringLibItemName()),
                      "fp_angle": fp.GetOrientationDegrees(),
                      "pad_angle": pad.GetOrientationDegrees(),
                      "shape": SHAPES.get(shape, str(shape)),
                      "oval": shape == pcbnew.PAD_SHAPE_OVAL,
                      "pth": pad.GetAttribute() == pcbnew.PAD_ATTRIB_PTH})
    print(json.dumps({"type": v.get("type"), "items": found}))
"""


def explain(work: Path, config: str) -> None:
    """Why freeroute @1 boards of `config` fail: counted violation types, and how many involve a
    pad, an oval PTH pad, and an oval PTH pad of a footprint rotated off the 0/180 axis."""
    import collections
    import csv
    import shutil
    import tempfile

    root = build(work, "d3" if config.startswith("d3") else "d2", 2)
    dirs = dict(__import__("pcbdata.core.tree", fromlist=["x"]).list_instances(
        root, config, "test"))
    report = work / "reports" / f"{config}-freeroute-k1" / "per_rollout.csv"
    types: collections.Counter = collections.Counter()
    kinds: collections.Counter = collections.Counter()
    footprints: collections.Counter = collections.Counter()
    boards_with: collections.Counter = collections.Counter()
    rows = [r for r in csv.DictReader(report.open()) if r["status"] == "ok"]
    for r in rows:
        if int(float(r["drv"])) - int(float(r["unconnected"])) <= 0:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            board = Path(tmp) / "board.kicad_pcb"
            shutil.copy(work / "runs" / f"{config}-freeroute" / r["board_id"] / "0.kicad_pcb",
                        board)
            for ext in ("kicad_pro", "kicad_dru"):
                if (dirs[r["board_id"]] / f"board.{ext}").is_file():
                    shutil.copy(dirs[r["board_id"]] / f"board.{ext}", Path(tmp) / f"board.{ext}")
            subprocess.run(["kicad-cli", "pcb", "drc", "--format", "json", "--all-track-errors",
                            "--severity-error", "-o", f"{tmp}/drc.json", str(board)],
                           capture_output=True, check=False)
            out = subprocess.run([sys.executable, "-c", _ITEMS, str(board), f"{tmp}/drc.json"],
                                 capture_output=True, text=True, check=False).stdout
        seen = set()
        for line in out.splitlines():
            v = json.loads(line)
            types[v["type"]] += 1
            padded = [i for i in v["items"] if i["item"] == "pad"]
            oval = [i for i in padded if i["oval"] and i["pth"]]
            turned = [i for i in oval if round(i["pad_angle"]) % 180 != 0]
            kind = ("oval PTH pad, turned 90/270 or off-axis" if turned else "oval PTH pad"
                    if oval else "other pad" if padded else "no pad (track/via/hole only)")
            kinds[kind] += 1
            for i in padded:
                shape = "oval PTH" if i["oval"] and i["pth"] else i["shape"]
                footprints[f"{i['footprint']} ({shape}, {i['pad_angle']:g} deg)"] += 1
            seen.add(v["type"])
        for t in seen:
            boards_with[t] += 1
    failing = sum(1 for r in rows if int(float(r["cp"])) == 0)
    print(f"{config} freeroute @1: {failing} of {len(rows)} boards not CP")
    print("| violation type | count | boards |\n| --- | ---: | ---: |")
    for t, n in types.most_common():
        print(f"| `{t}` | {n} | {boards_with[t]} |")
    print("\n| pads involved | violations |\n| --- | ---: |")
    for k, n in kinds.most_common():
        print(f"| {k} | {n} |")
    print("\nfootprints (pad shape, pad angle on the board) in the most violations:")
    for f, n in footprints.most_common(12):
        print(f"  {n:4d}  {f}")


LEVELS = ("d2-medium", "d2-hard", "d2-expert")
LEVEL_COLUMNS = ("CP @1 (%)", "CP @5 (%)", "CP+ @1 (%)", "CP+ @5 (%)", "Rout. @5", "DRV @1",
                 "DRV @5", "DRV+ @5", "WL @5 (mm)", "Via @5", "router s/board (median)")


def median_router_s(runs: Path, limit: int | None = None) -> float:
    import statistics

    boards = sorted(p for p in runs.iterdir() if p.is_dir())[: limit or None]
    values = [json.loads(m.read_text()).get("router_s") or 0.0
              for b in boards for m in b.glob("*.json")]
    return statistics.median(values) if values else float("nan")


def level_row(work: Path, config: str, boards: int, workers: int, rollouts: int = 5) -> str:
    """One calibration row: the first `boards` test boards of a level (@5 cells "-" when only
    one rollout is routed)."""
    if config == "d2":
        root, runs = work / "d2", work / "runs" / "d2-freeroute"
    else:
        root, runs = work / "levels" / config, work / "runs" / f"{config}-freeroute"
        if not (root / "manifest.json").is_file():
            pcbdata("build", "d2", "--level", config.removeprefix("d2-"), "--splits", "test",
                    "--count", str(boards), "--no-check", "--out", str(root))
        route(root, config, runs, workers, rollouts, limit=boards)
    s1 = evaluate(root, config, work / "reports" / f"levels-{config}-k1", 1, runs, "freeroute",
                  boards)
    s5 = (evaluate(root, config, work / "reports" / f"levels-{config}-k5", 5, runs,
                   "freeroute", boards) if rollouts == 5 else None)
    at5 = s5 or s1  # Rout., DRV+, WL, Via of @1 when only one rollout was routed
    cells = [_pct(s1["cp"]), _pct(s5["cp"]) if s5 else "-", _pct(s1["cp_strict"]),
             _pct(s5["cp_strict"]) if s5 else "-", f"{at5['rout']:.3f}", f"{s1['drv']:.2f}",
             f"{s5['drv']:.2f}" if s5 else "-", f"{at5['drv_strict']:.2f}",
             f"{at5['wl']:.1f}", f"{at5['via']:.2f}", f"{median_router_s(runs, boards):.2f}"]
    return f"| `{config}` ({at5['n_boards']}) | freeroute | " + " | ".join(cells) + " |"


def levels_table(work: Path, boards: int, workers: int, rollouts: int) -> None:
    rows = [f"| level (config) | router | {' | '.join(LEVEL_COLUMNS)} |",
            "| --- | --- | " + " | ".join("---:" for _ in LEVEL_COLUMNS) + " |"]
    for config in ("d2", *LEVELS):
        rows.append(level_row(work, config, boards, workers, 5 if config == "d2" else rollouts))
        print("\n".join(rows), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", default="/work/tables-work")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", default="d2,d3-a,d3-b")
    parser.add_argument("--prefix", action="store_true", help="also route @1 pre-fix")
    parser.add_argument("--kicad-tools", type=int, default=0, metavar="N",
                        help="kicad-tools @1 on the first N D2 test boards (0: none)")
    parser.add_argument("--levels", type=int, default=0, metavar="N",
                        help="the level calibration table on the first N test boards (0: none)")
    parser.add_argument("--level-rollouts", type=int, choices=(1, 5), default=5,
                        help="rollouts for the harder levels (1: @1 columns only)")
    parser.add_argument("--explain", metavar="CONFIG",
                        help="only: counted violations of freeroute @1 by type and pad kind")
    args = parser.parse_args()
    work = Path(args.work)
    if args.explain:
        sys.path.insert(0, str(REPO))
        explain(work, args.explain)
        return
    if args.levels:
        build(work, "d2", args.workers)
        route(work / "d2", "d2", work / "runs" / "d2-freeroute", args.workers, 5)
        levels_table(work, args.levels, args.workers, args.level_rollouts)
        return
    rows = [f"| set | method | {' | '.join(COLUMNS)} |",
            "| --- | --- | " + " | ".join("---:" for _ in COLUMNS) + " |"]
    for config in args.only.split(","):
        label, family = SETS[config]
        root = build(work, family, args.workers)
        runs = work / "runs" / f"{config}-freeroute"
        if family == "d3":
            s = evaluate(root, config, work / "reports" / f"{config}-reference", 1, None,
                         "Reference")
            rows.append(row(label, "Reference", s))
            print(f"{config} Reference: Pot. {s['pot']:.2f} (strict count), "
                  f"{s['pot_evaluation']:.2f} (evaluation count)", file=sys.stderr)
        route(root, config, runs, args.workers, 5)
        for k in (1, 5):
            s = evaluate(root, config, work / "reports" / f"{config}-freeroute-k{k}", k, runs,
                         "freeroute")
            rows.append(row(label, f"freeroute @{k}", s))
        if args.prefix and config in ("d2", "d3-a"):
            old = work / "runs" / f"{config}-freeroute-prefix"
            route_prefix(root, config, old, args.workers)
            s = evaluate(root, config, work / "reports" / f"{config}-freeroute-prefix-k1", 1,
                         old, "freeroute pre-fix")
            rows.append(row(label, "freeroute pre-fix @1", s))
        if args.kicad_tools and config == "d2":
            kt = work / "runs" / "d2-kicad-tools"
            route(root, config, kt, args.workers, 1, "kicad-tools", args.kicad_tools)
            s = evaluate(root, config, work / "reports" / "d2-kicad-tools-k1", 1, kt,
                         "kicad-tools", args.kicad_tools)
            rows.append(row(f"{label}, first", "kicad-tools @1", s))
            same = work / "reports" / f"d2-freeroute-first{args.kicad_tools}-k1"
            s = evaluate(root, config, same, 1, runs, "freeroute", args.kicad_tools)
            rows.append(row(f"{label}, first", "freeroute @1 (same boards)", s))
        print("\n".join(rows), flush=True)
        print(f"median router s/board, {config} freeroute: {median_router_s(runs):.2f}",
              file=sys.stderr)


if __name__ == "__main__":
    main()

"""The README's result cells: one bundled method on one test split, run and scored, kept as data.

`run` routes a built set's test split with an agent (`pcbdata rollout`), a baseline router
(`pcbdata route`) or takes its reference boards, scores it with `pcbdata eval` and writes one
record, `bench/results/baselines/<config>__<method>.json`: the commands, the machine, the date,
the load before and after, the set it scored (version, manifest sha256), the evaluator version
and the figures (CP, CP+, Pot., Rout., DRV, WL, Via; time per episode as mean, median and max).
Both steps resume (rollouts with a JSON are skipped, eval reuses its cache), so a killed run is
started again with the same command. `table` prints the README's table from every record and the
published rows of `bench/published.json` (SPEC section 7.5), nothing typed by hand.

    python bench/baselines.py run SET --config d3-b --method scripted --rollouts 5 [--work DIR]
    python bench/baselines.py run SET --config d3-c --method freeroute --rollouts 1
    python bench/baselines.py run SET --config d3-c --method reference
    python bench/baselines.py table [--write README.md]
    python bench/baselines.py collect --work DIR   # every record's results.json, bench/results/
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
RESULTS = HERE / "results"  # results.json files (`pcbdata leaderboard` reads them)
RECORDS = RESULTS / "baselines"  # one record per README cell
PUBLISHED = HERE / "published.json"
ROUTERS = ("freeroute", "kicad-tools")
#: Columns of the table, in the paper's shape (CP, Pot., Rout., Time) plus DRV, WL, Via.
SPLITS = {"d2": "D2 test (128)", "d3-a": "D3-A test (99)", "d3-b": "D3-B test (10)",
          "d3-c": "D3-C test (10)"}
METHODS = {"reference": "Reference (the real routing)", "scripted": "`scripted`",
           "scripted-shove": "`scripted-shove`", "freeroute": "`freeroute` (Specctra round trip)",
           "negotiated": "`negotiated`",
           "policy": "learned `policy` (trained on D2 only)", "random": "`random`"}


def pcbdata(*args: str) -> str:
    """Runs `python -m pcbdata ARGS` from this checkout; returns the command line."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    subprocess.run([sys.executable, "-m", "pcbdata", *args], env=env, check=True)
    return "pcbdata " + " ".join(args)


def _load() -> str:
    """The 1, 5 and 15 minute load averages."""
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def _times(runs: Path) -> list[float]:
    out = []
    for sidecar in sorted(runs.glob("*/*.json")):
        value = json.loads(sidecar.read_text()).get("time_s")
        if isinstance(value, (int, float)):
            out.append(float(value))
    return out


def run(args) -> Path:
    from _measure import machine

    work = Path(args.work) / f"{args.config}__{args.method}"
    runs, report = work / "runs", work / "report"
    started, load_before = datetime.now(UTC).isoformat(timespec="minutes"), _load()
    common = [str(args.set), "--config", args.config, "--split", "test"]
    commands = []
    k = 1 if args.method == "reference" else args.rollouts
    if args.method == "reference":
        commands.append(pcbdata("eval", *common, "--reference", "--out", str(report),
                                "--workers", str(args.eval_workers)))
    else:
        if args.method in ROUTERS:
            commands.append(pcbdata("route", *common, "--router", args.method, "--rollouts",
                                    str(k), "--out", str(runs), "--workers", str(args.workers)))
        else:
            commands.append(pcbdata("rollout", *common, "--agent", args.method, "--rollouts",
                                    str(k), "--drc", args.drc, "--out", str(runs), "--workers",
                                    str(args.workers)))
        commands.append(pcbdata("eval", *common, "--runs", str(runs), "--k", str(k), "--out",
                                str(report), "--workers", str(args.eval_workers),
                                "--name", args.method))
    summary = json.loads((report / "summary.json").read_text())
    times = _times(runs) if runs.is_dir() else []
    record = {
        "config": args.config, "split": "test", "method": args.method, "k": k,
        "drc": None if args.method in (*ROUTERS, "reference") else args.drc,
        "commands": commands, "machine": machine(), "started": started,
        "finished": datetime.now(UTC).isoformat(timespec="minutes"),
        "load_before": load_before, "load_after": _load(),
        "set": {k2: summary["set"].get(k2) for k2 in ("set_version", "manifest_sha256",
                                                      "release")},
        "evaluator_version": summary["evaluator_version"], "n_boards": summary["n_boards"],
        "figures": {name: summary[name] for name in ("cp", "cp_strict", "pot", "rout", "drv",
                                                     "drv_strict", "wl", "via")},
        "time_s": None if not times else {
            "mean": statistics.fmean(times), "median": statistics.median(times),
            "max": max(times), "n": len(times)},
    }
    RECORDS.mkdir(parents=True, exist_ok=True)
    out = RECORDS / f"{args.config}__{args.method}.json"
    out.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    print(f"wrote {out}", file=sys.stderr)
    return out


def collect(args) -> None:
    """Each record's `results.json` (the schema `pcbdata eval` writes) as
    `bench/results/<config>__<method>.json`: the eval is run again on the record's runs (its
    cache answers), so `pcbdata leaderboard bench/results/*.json --out site` reads them all."""
    for path in sorted(RECORDS.glob("*__*.json")):
        record = json.loads(path.read_text())
        work = Path(args.work) / path.stem
        eval_command = next(c for c in record["commands"] if c.startswith("pcbdata eval"))
        words = eval_command.split()[1:]
        if "--name" not in words and "--reference" not in words:
            words += ["--name", record["method"]]
        pcbdata(*words)
        report = work / "report" / "results.json"
        if not report.is_file():
            print(f"{path.name}: no results.json in {report.parent}", file=sys.stderr)
            continue
        out = RESULTS / f"{path.stem}.json"
        out.write_text(report.read_text())
        print(f"wrote {out}", file=sys.stderr)


def _cell(record: dict) -> str:
    f, t = record["figures"], record["time_s"]
    time = "-" if not t else f"{t['mean']:.2f} ({t['median']:.2f})"
    return f"{100 * f['cp']:.1f} / {f['pot']:.2f} / {f['rout']:.3f} / {time}"


def table() -> str:
    """The README's table: our rows (CP %, Pot., Rout., mean (median) s per episode), then the
    published rows as published (CP as a fraction, mean s)."""
    records = [json.loads(p.read_text()) for p in sorted(RECORDS.glob("*.json"))]
    header = "| method | " + " | ".join(SPLITS.values()) + " |"
    lines = [header, "| --- " * (len(SPLITS) + 1) + "|"]
    for method, label in METHODS.items():
        cells = []
        for config in SPLITS:
            found = [r for r in records if r["config"] == config and r["method"] == method]
            at = "" if not found or method == "reference" else f" @{found[0]['k']}"
            cells.append(f"{_cell(found[0])}{at}" if found else "-")
        if any(c != "-" for c in cells):
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
    published = json.loads(PUBLISHED.read_text())
    for row in published["rows"]:
        cells = [_published_cell(row["cells"].get(config)) for config in SPLITS]
        lines.append(f"| {row['method']} (published) | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


BEGIN, END = "<!-- baselines table: begin -->", "<!-- baselines table: end -->"


def readme_table(text: str) -> str:
    """The table between the README's markers."""
    return text.split(BEGIN, 1)[1].split(END, 1)[0].strip("\n") + "\n"


def write_readme(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    path.write_text(f"{head}{BEGIN}\n{table()}{END}{tail}", encoding="utf-8")


def _published_cell(cell: dict | None) -> str:
    if not cell:
        return "-"
    time = "-" if cell.get("time") is None else f"{cell['time']:.2f}"
    return f"{cell['cp']:.2f} / {cell['pot']:.2f} / {cell['rout']:.2f} / {time}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="verb", required=True)
    r = sub.add_parser("run", help="route (or take the reference), score, record")
    r.add_argument("set", type=Path)
    r.add_argument("--config", required=True, choices=sorted(SPLITS))
    r.add_argument("--method", required=True, choices=sorted(METHODS))
    r.add_argument("--rollouts", type=int, default=5)
    r.add_argument("--drc", default="terminal", choices=("terminal", "step"))
    r.add_argument("--workers", type=int, default=2)
    r.add_argument("--eval-workers", type=int, default=8)
    r.add_argument("--work", default="/tmp/pcbdata-baselines",
                   help="where the runs and reports go (never the repository)")
    t = sub.add_parser("table", help="print the README's table from the records")
    t.add_argument("--write", type=Path, metavar="README",
                   help="put it between the README's baselines markers instead")
    c = sub.add_parser("collect", help="each record's results.json into bench/results/")
    c.add_argument("--work", default="/tmp/pcbdata-baselines")
    args = parser.parse_args()
    if args.verb == "run":
        run(args)
    elif args.verb == "collect":
        collect(args)
    elif args.write:
        write_readme(args.write)
    else:
        print(table(), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())

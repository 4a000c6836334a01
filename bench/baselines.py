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
    python bench/baselines.py run SET --config d2-hard --method scripted --rollouts 1 --limit 64
    python bench/baselines.py noise SET --config d2 --method scripted --repeats 5 --limit 32
    python bench/baselines.py table [--write README.md]    # and the levels table, docs/sets.md
    python bench/baselines.py collect --work DIR   # every record's results.json, bench/results/

`run` takes any config a set holds: the README's cells (D2, D3-A/B/C), D1 grids and the levels of
D2 and D2R (`levels_table`, written into docs/sets.md). `noise` runs one cell `--repeats` times
into fresh folders and records the spread of the time per episode between repeats (the noise
floor of the timing columns), `bench/results/noise/<config>__<method>.json`.
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


def pcbdata(*args: str, allowed: tuple[int, ...] = (0,)) -> str:
    """Runs `python -m pcbdata ARGS` from this checkout; returns the command line. An exit
    code outside `allowed` is an error."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    code = subprocess.run([sys.executable, "-m", "pcbdata", *args], env=env).returncode
    if code not in allowed:
        raise SystemExit(f"pcbdata {' '.join(args)}: exit {code}")
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
    work = Path(args.work) / record_name(args.config, args.method, args.limit)
    record = measure(args, work)
    RECORDS.mkdir(parents=True, exist_ok=True)
    out = RECORDS / f"{record_name(args.config, args.method, args.limit)}.json"
    out.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    print(f"wrote {out}", file=sys.stderr)
    return out


def record_name(config: str, method: str, limit: int | None) -> str:
    """`<config>__<method>`, with `__first<N>` for a run on the first N test boards."""
    return f"{config}__{method}" + (f"__first{limit}" if limit else "")


def measure(args, work: Path) -> dict:
    """Routes (or takes the reference), scores, and returns the record of one cell."""
    from _measure import machine

    runs, report = work / "runs", work / "report"
    started, load_before = datetime.now(UTC).isoformat(timespec="minutes"), _load()
    common = [str(args.set), "--config", args.config, "--split", "test"]
    limit = ["--limit", str(args.limit)] if args.limit else []
    timeout = ["--rollout-timeout", str(args.rollout_timeout)] if args.rollout_timeout else []
    commands = []
    k = 1 if args.method == "reference" else args.rollouts
    if args.method == "reference":
        commands.append(pcbdata("eval", *common, "--reference", "--out", str(report),
                                "--workers", str(args.eval_workers), *limit))
    else:
        if args.method in ROUTERS:
            commands.append(pcbdata("route", *common, "--router", args.method, "--rollouts",
                                    str(k), "--out", str(runs), "--workers", str(args.workers),
                                    *limit))
        else:
            # exit 3: rollouts past --rollout-timeout have no board; eval scores them CP 0
            commands.append(pcbdata("rollout", *common, "--agent", args.method, "--rollouts",
                                    str(k), "--drc", args.drc, "--out", str(runs), "--workers",
                                    str(args.workers), *limit, *timeout,
                                    allowed=(0, 3) if timeout else (0,)))
        commands.append(pcbdata("eval", *common, "--runs", str(runs), "--k", str(k), "--out",
                                str(report), "--workers", str(args.eval_workers),
                                "--name", args.method, *limit))
    summary = json.loads((report / "summary.json").read_text())
    times = _times(runs) if runs.is_dir() else []
    return {
        "config": args.config, "split": "test", "method": args.method, "k": k,
        "limit": args.limit,
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


def noise(args) -> Path:
    """One cell measured `--repeats` times, each into a fresh folder (nothing reused): the
    spread of the time per episode between repeats is the timing columns' noise floor."""
    repeats = []
    for i in range(args.repeats):
        name = record_name(args.config, args.method, args.limit)
        work = Path(args.work) / "noise" / name / f"repeat-{i}"
        if work.exists():
            import shutil

            shutil.rmtree(work)
        repeats.append(measure(args, work))
    medians = [r["time_s"]["median"] for r in repeats]
    means = [r["time_s"]["mean"] for r in repeats]
    record = {"config": args.config, "method": args.method, "k": repeats[0]["k"],
              "limit": args.limit, "repeats": repeats,
              "spread": {name: _spread(values) for name, values in
                         (("median_s", medians), ("mean_s", means))},
              "figures_identical": len({json.dumps(r["figures"], sort_keys=True)
                                        for r in repeats}) == 1}
    out = RESULTS / "noise" / f"{record_name(args.config, args.method, args.limit)}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    print(f"wrote {out}: median s {record['spread']['median_s']}", file=sys.stderr)
    return out


def _spread(values: list[float]) -> dict:
    mean = statistics.fmean(values)
    return {"values": values, "mean": mean, "std": statistics.stdev(values),
            "min": min(values), "max": max(values),
            "relative_range": (max(values) - min(values)) / mean if mean else None}


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
            found = [r for r in records if r["config"] == config and r["method"] == method
                     and not _is_level(r)]
            at = "" if not found or method == "reference" else f" @{found[0]['k']}"
            cells.append(f"{_cell(found[0])}{at}" if found else "-")
        if any(c != "-" for c in cells):
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
    published = json.loads(PUBLISHED.read_text())
    for row in published["rows"]:
        cells = [_published_cell(row["cells"].get(config)) for config in SPLITS]
        lines.append(f"| {row['method']} (published) | " + " | ".join(cells) + " |")
    return "\n".join(lines + noise_lines()) + "\n"


def noise_lines() -> list[str]:
    """One sentence per noise record (`bench/results/noise/`): the timing noise floor."""
    out = []
    for path in sorted((RESULTS / "noise").glob("*.json")):
        r = json.loads(path.read_text())
        med, loads = r["spread"]["median_s"], [x["load_before"] for x in r["repeats"]]
        same = "the same" if r["figures_identical"] else "NOT the same"
        out += ["", f"Timing noise floor ({path.name}): `{r['method']}` @{r['k']} on the first "
                f"{r['limit']} `{r['config']}` test boards, {len(r['repeats'])} repeats into "
                f"fresh folders at load {loads[0].split()[0]}: median seconds per episode "
                f"{med['min']:.3f}-{med['max']:.3f} (std {med['std']:.3f}, range "
                f"{100 * med['relative_range']:.0f} % of the mean); CP, Pot., WL and vias "
                f"{same} in every repeat. Time differences within that range are not real."]
    return out


#: The levels table (docs/sets.md): scripted @1 on the first 64 test boards of every D2 and
#: D2R level, and the D1 grids.

def _is_level(record: dict) -> bool:
    """A record of the levels table: a run on the first N boards, or of a D1 grid."""
    return bool(record.get("limit")) or record["config"].split("-")[0] == "d1"


def levels_table() -> str:
    """CP %, Pot., Rout., mean (median) s per episode, DRV of each level record, in the
    registry's order of configs (levels by rank), with its boards and k."""
    sys.path.insert(0, str(REPO))
    from pcbdata.sets.configs import registry

    ranked = list(registry())  # D1 grids, each family's levels by rank, D3 tiers

    def rank(config: str) -> int:
        return ranked.index(config) if config in ranked else len(ranked)

    records = [json.loads(p.read_text()) for p in sorted(RECORDS.glob("*.json"))]
    records = sorted((r for r in records if _is_level(r)),
                     key=lambda r: (rank(r["config"]), r["config"], r["method"]))
    lines = ["| config | set version | method | boards | CP % / Pot. / Rout. / mean (median) s "
             "| DRV |", "| --- | --- | --- | --- | --- | --- |"]
    for r in records:
        lines.append(f"| `{r['config']}` | {r['set']['set_version']} | `{r['method']}` "
                     f"@{r['k']} | {r['n_boards']} | {_cell(r)} | {r['figures']['drv']:.2f} |")
    return "\n".join(lines) + "\n"


BEGIN, END = "<!-- baselines table: begin -->", "<!-- baselines table: end -->"
LEVELS_BEGIN, LEVELS_END = "<!-- levels table: begin -->", "<!-- levels table: end -->"


def readme_table(text: str, begin: str = BEGIN, end: str = END) -> str:
    """The table between a document's markers."""
    return text.split(begin, 1)[1].split(end, 1)[0].strip("\n") + "\n"


def write_between(path: Path, body: str, begin: str = BEGIN, end: str = END) -> None:
    text = path.read_text(encoding="utf-8")
    head, rest = text.split(begin, 1)
    tail = rest.split(end, 1)[1]
    path.write_text(f"{head}{begin}\n{body}{end}{tail}", encoding="utf-8")


def write_readme(path: Path) -> None:
    """The README's table, and the levels table in docs/sets.md beside it."""
    write_between(path, table())
    sets_doc = path.resolve().parent / "docs" / "sets.md"
    write_between(sets_doc, levels_table(), LEVELS_BEGIN, LEVELS_END)


def _published_cell(cell: dict | None) -> str:
    if not cell:
        return "-"
    time = "-" if cell.get("time") is None else f"{cell['time']:.2f}"
    return f"{cell['cp']:.2f} / {cell['pot']:.2f} / {cell['rout']:.2f} / {time}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="verb", required=True)
    r = sub.add_parser("run", help="route (or take the reference), score, record")
    n = sub.add_parser("noise", help="one cell --repeats times: the timing noise floor")
    n.add_argument("--repeats", type=int, default=5)
    for p in (r, n):
        p.add_argument("set", type=Path)
        p.add_argument("--config", required=True, help="any config the set holds")
        p.add_argument("--method", required=True, choices=sorted(METHODS) + ["d1"])
        p.add_argument("--rollouts", type=int, default=5)
        p.add_argument("--limit", type=int, default=None, help="only the first N test boards")
        p.add_argument("--rollout-timeout", type=float, default=None, metavar="SECONDS",
                       help="an agent's episode longer than this ends without a board")
        p.add_argument("--drc", default="terminal", choices=("terminal", "step"))
        p.add_argument("--workers", type=int, default=2)
        p.add_argument("--eval-workers", type=int, default=8)
        p.add_argument("--work", default="/tmp/pcbdata-baselines",
                       help="where the runs and reports go (never the repository)")
    t = sub.add_parser("table", help="print the README's table from the records")
    t.add_argument("--write", type=Path, metavar="README",
                   help="put it between the README's baselines markers instead")
    c = sub.add_parser("collect", help="each record's results.json into bench/results/")
    c.add_argument("--work", default="/tmp/pcbdata-baselines")
    args = parser.parse_args()
    if args.verb == "run":
        run(args)
    elif args.verb == "noise":
        noise(args)
    elif args.verb == "collect":
        collect(args)
    elif args.write:
        write_readme(args.write)
    else:
        print(table(), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Per-board table of `--agent negotiated` runs: connections planned, the ones left open by
cause (boxed-in pin, congestion, budget), route calls, the plan's work (link checks), rip-ups,
rounds, and what KiCad found at the end (unconnected items, DRV), with each rollout's time;
beside it, where given, another agent's runs on the same boards (U and DRV per board, best
rollout by fewest U).

    python bench/negotiated_table.py RUNS [--vs OTHER_RUNS [--vs-name NAME]]
        [--vs-record bench/runs/EARLIER.json] [--json bench/runs/X.json] [--note TEXT]

`--vs-record` takes the other agent's columns from an earlier record of this table (its rows'
`NAME_U`, `NAME_DRV` and `NAME_s`, NAME from `--vs-name`), for runs no longer on the machine.

The JSON keeps the command, the date, the machine and its load with the rows.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
from datetime import UTC, datetime
from pathlib import Path

CAUSES = ("boxed_in", "congestion", "budget")


def rollouts(runs: Path) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for sidecar in sorted(runs.glob("*/*.json")):
        out.setdefault(sidecar.parent.name, []).append(json.loads(sidecar.read_text()))
    return out


def rows(runs: Path, other: Path | None, name: str = "other") -> list[dict]:
    mine, theirs = rollouts(runs), rollouts(other) if other else {}
    table = []
    for board_id, records in sorted(mine.items()):
        best = min(records, key=lambda r: (r["unconnected"], r["drv"], r["rollout"]))
        report = best.get("agent_report") or {}
        row = {"board": board_id, "rollouts": len(records),
               "connections": report.get("connections"),
               **{c: (report.get("open") or {}).get(c) for c in CAUSES},
               "route_calls": report.get("route_calls"), "work": report.get("work"),
               "rips": report.get("rips"),
               "rounds": report.get("rounds"), "U": best["unconnected"], "DRV": best["drv"],
               "clean": sum(r["unconnected"] == 0 and r["drv"] == 0 for r in records),
               "median_s": statistics.median(r["time_s"] for r in records)}
        if board_id in theirs:
            other_best = min(theirs[board_id], key=lambda r: (r["unconnected"], r["drv"]))
            row.update({f"{name}_U": other_best["unconnected"],
                        f"{name}_DRV": other_best["drv"],
                        f"{name}_s": statistics.median(r["time_s"] for r in theirs[board_id])})
        table.append(row)
    return table


def markdown(table: list[dict]) -> str:
    columns = list(table[0]) if table else []
    lines = ["| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]
    for row in table:
        cells = [f"{v:.1f}" if isinstance(v, float) else ("-" if v is None else str(v))
                 for v in row.values()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path, help="a `pcbdata rollout --agent negotiated` folder")
    parser.add_argument("--vs", type=Path, help="another agent's runs on the same boards")
    parser.add_argument("--vs-name", default="other", help="prefix of the --vs columns")
    parser.add_argument("--vs-record", type=Path,
                        help="an earlier record of this table: its --vs-name columns")
    parser.add_argument("--json", type=Path, help="write the rows here")
    parser.add_argument("--note", default="", help="how the runs were made (commands, load)")
    args = parser.parse_args()
    table = rows(args.runs, args.vs, args.vs_name)
    if args.vs_record:
        earlier = {r["board"]: r for r in json.loads(args.vs_record.read_text())["rows"]}
        for row in table:
            row.update({k: v for k, v in earlier.get(row["board"], {}).items()
                        if k.startswith(f"{args.vs_name}_")})
    print(markdown(table), end="")
    if args.json:
        record = {"command": " ".join(sys.argv), "note": args.note,
                  "date": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
                  "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                              "python": platform.python_version()},
                  "load_1_5_15": list(os.getloadavg()), "rows": table}
        args.json.write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

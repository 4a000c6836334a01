"""Prints the Markdown table of one dated run under bench/runs/, as the docs show it.

    python bench/doc_tables.py bench/runs/2026-11-26-env-agents.json
    python bench/doc_tables.py bench/runs/2026-11-22-ray.json --table projection
    python bench/doc_tables.py bench/runs/2026-11-26-realism-ks.json --column statistic ...

A run file holds `command`, `machine`, `date`, `load`, `figures` and `notes`; `figures` is a list
of rows (dicts), or a dict of such lists by table name.
"""
from __future__ import annotations

import argparse
import json
import sys


def markdown(rows: list[dict], only: list[str] | None = None) -> str:
    """One Markdown table: columns in first-seen order, numeric columns right-aligned, the
    floats of a column with as many decimals as the longest of them."""
    columns: list[str] = []
    for row in rows:
        columns += [key for key in row if key not in columns]
    columns = [c for c in columns if not only or c in only]
    values = {c: [row.get(c, "") for row in rows] for c in columns}
    numeric = {c: any(v != "" for v in values[c]) and all(
        isinstance(v, (int, float)) or v == "" for v in values[c]) for c in columns}
    decimals = {c: max([len(repr(v).partition(".")[2]) for v in values[c]
                        if isinstance(v, float)], default=0) for c in columns}

    def cell(c: str, v: object) -> str:
        return f"{v:.{decimals[c]}f}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(columns) + " |",
             "|" + "|".join(" ---: " if numeric[c] else " --- " for c in columns) + "|"]
    for i in range(len(rows)):
        lines.append("| " + " | ".join(cell(c, values[c][i]) for c in columns) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a bench/runs/*.json file")
    parser.add_argument("--table", help="the table to print, when `figures` holds several")
    parser.add_argument("--column", action="append", help="print only this column (repeatable)")
    args = parser.parse_args(argv)
    with open(args.run, encoding="utf-8") as handle:
        run = json.load(handle)
    figures = run["figures"]
    tables = figures if isinstance(figures, dict) else {"": figures}
    if args.table is not None:
        if args.table not in tables:
            parser.error(f"no table {args.table!r}; the file has: {', '.join(tables)}")
        tables = {args.table: tables[args.table]}
    print("\n\n".join(markdown(rows, args.column) for rows in tables.values()))
    print(f"\n{run['date']}; {run['machine']}; load: {run['load']}; `{run['command']}`",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

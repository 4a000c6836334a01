"""The environment's copper-changing step without its DRC: a routed board's tracks and vias laid
again on its unrouted instance, a few edits a step, in a KiCad worker
(`pcbdata.kicad.routing_session.apply`: KiCad adds the items, brings its connectivity up to date and
answers with the snapshot the environment reads). Prints milliseconds per step per board.

    python bench/bench_snapshot.py SET --config d3-c [--boards NAME ...] [--batch 2]
        [--json OUT]

Boards are those of the split with a reference routing (`reference.kicad_pcb`). Run it from
two checkouts to compare two versions of the worker (`farm-bench --vs` for whole processes).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def replay(board: str, project: str, rules: str | None, reference: str, batch: int) -> dict:
    """In a KiCad worker: the reference's copper laid again `batch` edits a step; the steps,
    edits and seconds of the steps."""
    import tempfile

    from pcbdata.evaluator.metrics import STRICT_WARNINGS
    from pcbdata.kicad import routing_session

    with tempfile.TemporaryDirectory() as stage, tempfile.TemporaryDirectory() as folder:
        edits = routing_session.copper_edits(reference, folder)
        routing_session.open_instance(board, project, rules, stage, sorted(STRICT_WARNINGS))
        clock = time.perf_counter()
        steps = 0
        for start in range(0, len(edits), batch):
            routing_session.apply(edits[start:start + batch])
            steps += 1
        seconds = time.perf_counter() - clock
        routing_session.close()
    return {"steps": steps, "edits": len(edits), "seconds": round(seconds, 3),
            "ms_per_step": round(1000 * seconds / max(steps, 1), 2)}


def main(argv: list[str] | None = None) -> None:
    from _measure import board_arguments, chosen_boards, machine

    from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, REFERENCE_FILE, RULES_FILE
    from pcbdata.kicad.pool import KicadPool

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    board_arguments(parser)
    parser.add_argument("--batch", type=int, default=2, help="edits a step (default 2)")
    parser.add_argument("--json", help="write the rows and the machine here")
    args = parser.parse_args(argv)
    folder = Path(args.set) / args.config / args.split
    if not folder.is_dir():
        raise SystemExit(f"{folder}: no such split folder (SET, --config and --split name it)")
    names = sorted(p.name for p in folder.iterdir() if (p / REFERENCE_FILE).is_file())
    boards = [folder / name for name in chosen_boards(names, args.boards)]
    if not boards:
        raise SystemExit(f"{folder}: no board with a {REFERENCE_FILE}")
    here = str(Path(__file__).resolve().parent)
    env = {"PYTHONPATH": os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH")) if p)}
    jobs = [(str(p / BOARD_FILE), str(p / PROJECT_FILE),
             str(p / RULES_FILE) if (p / RULES_FILE).is_file() else None,
             str(p / REFERENCE_FILE), args.batch) for p in boards]
    rows = []
    with KicadPool(workers=1, task_timeout=3600, env=env) as pool:
        for outcome in pool.map("bench_snapshot:replay", jobs):
            board = boards[outcome.index].name
            if not outcome.ok:
                raise SystemExit(f"{board}: {outcome.error}")
            rows.append({"board": board, **outcome.value})
            print(json.dumps(rows[-1]), flush=True)
    total = sum(r["seconds"] for r in rows)
    steps = sum(r["steps"] for r in rows)
    print(f"{len(rows)} boards, {steps} steps, {total:.2f} s, "
          f"{1000 * total / max(steps, 1):.2f} ms a step")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "command": "python bench/bench_snapshot.py " + " ".join(sys.argv[1:]),
            "machine": machine(), "rows": rows,
            "summary": {"boards": len(rows), "steps": steps, "seconds": round(total, 2)}},
            indent=1) + "\n")


if __name__ == "__main__":
    main()

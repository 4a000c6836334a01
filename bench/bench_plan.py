"""Plans of the negotiated planner alone (no copper laid): per board its open connections,
route calls, the plan's digest (sha256 of its wires and open connections: equal digests are
equal plans) and the CPU seconds of planning.

    python bench/bench_plan.py SET --config d3-b [--boards NAME ...] [--json OUT]

Run it twice, with and without ``PCBDATA_NO_NUMBA=1``, to compare the compiled clearance test
with the reference form (same digests, the time apart); `--both` does that in one process and
writes both into `--json`. `--proofs` plans each board with the searches' proofs that no path
exists (`WalkaroundRouter.prove_separation`, the planner's default) and without them: the same
plans where the budget is not reached, the work and the time apart. `--repair` plans each board
with the repair after the rounds (`Negotiator._repair`, the default) and without it
(`repair_work=0`): the same plans where the rounds complete them, and what the repair adds
elsewhere. `--budget-work` and `--repair-work` give every plan smaller budgets: level c boards
spend the whole default budget, minutes a board, and a smaller one compares two versions of
the code on the same counted work (run this file from each version's checkout). Each row and
the record's `work_by_search` split the plans' link checks by the kind of search that made
them (a walkaround leg, a layered search, a rip-up search) and whether it found a way.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import pcbdata.env  # noqa: E402
from pcbdata.agents.negotiated import plan_board  # noqa: E402

#: The planner's options of each form that is not its default.
OPTIONS: dict[str, dict] = {"no_proofs": {"prove_separation": False},
                            "no_repair": {"repair_work": 0}}


def digest(plan) -> str:
    text = repr((sorted(plan.wires.items()), sorted(plan.open.items())))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def plan_once(env, board_id: str, **options) -> dict:
    env.reset(seed=0, options={"board_id": board_id})
    view = env.unwrapped.board_view()
    clock = time.process_time()
    plan, _ = plan_board(view, **options)
    seconds = time.process_time() - clock
    return {"open": len(plan.open), "route_calls": plan.stats.get("route_calls"),
            "work": plan.stats.get("work"),
            "rips": plan.stats.get("rips"), "repaired": plan.stats.get("repaired"),
            "variant": plan.stats.get("variant"),
            "work_by_search": plan.stats.get("work_by_search"),
            "digest": digest(plan),
            "cpu_s": round(seconds, 2)}


def main(argv: list[str] | None = None) -> None:
    from _measure import board_arguments, chosen_boards

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    board_arguments(parser)
    pair = parser.add_mutually_exclusive_group()
    pair.add_argument("--both", action="store_true",
                      help="each board compiled, then with PCBDATA_NO_NUMBA=1")
    pair.add_argument("--proofs", action="store_true",
                      help="each board with the searches' proofs, then without them")
    pair.add_argument("--repair", action="store_true",
                      help="each board with the repair after the rounds, then without it")
    parser.add_argument("--budget-work", type=int, default=None,
                        help="the plans' work budget (default: the planner's, BUDGET_WORK)")
    parser.add_argument("--repair-work", type=int, default=None,
                        help="the repair's work budget (default: the planner's, REPAIR_WORK)")
    parser.add_argument("--json", help="write the rows and the machine here")
    args = parser.parse_args(argv)
    budgets = {k: v for k, v in (("budget_work", args.budget_work),
                                 ("repair_work", args.repair_work)) if v is not None}
    folder = Path(args.set) / args.config / args.split
    ids = chosen_boards(sorted(p.name for p in folder.iterdir() if p.is_dir()), args.boards)
    env = pcbdata.env.make(args.set, args.config, split=args.split, drc="terminal")
    rows = []
    started = time.strftime("%Y-%m-%dT%H:%M+00:00", time.gmtime())
    try:
        for board_id in ids:
            row = {"board": board_id}
            forms = (("compiled", "reference") if args.both
                     else ("proofs", "no_proofs") if args.proofs
                     else ("repair", "no_repair") if args.repair else ("as_set",))
            for form in forms:
                if args.both:
                    os.environ["PCBDATA_NO_NUMBA"] = "1" if form == "reference" else "0"
                options = {**budgets, **OPTIONS.get(form, {})}
                row[form] = plan_once(env, board_id, **options)
            if len(forms) == 2:
                row["same_plan"] = row[forms[0]]["digest"] == row[forms[1]]["digest"]
            rows.append(row)
            print(json.dumps(row), flush=True)
    finally:
        env.close()
    if args.json:
        record = {"command": "python bench/bench_plan.py " + " ".join(sys.argv[1:]),
                  "started": started,
                  "finished": time.strftime("%Y-%m-%dT%H:%M+00:00", time.gmtime()),
                  "machine": f"{os.cpu_count()} cores, {platform.platform()}",
                  "load_after": " ".join(f"{x:.2f}" for x in os.getloadavg()),
                  "rows": rows}
        record["work_by_search"] = {form: _work_shares(r[form]["work_by_search"] for r in rows)
                                    for form in forms}
        if len(forms) == 2:
            record["summary"] = {"boards": len(rows),
                                 "same_plan": sum(r["same_plan"] for r in rows)}
            for form in forms:
                record["summary"][f"{form}_cpu_s"] = round(sum(r[form]["cpu_s"] for r in rows), 1)
                record["summary"][f"{form}_work"] = sum(r[form]["work"] for r in rows)
        Path(args.json).write_text(json.dumps(record, indent=1) + "\n")


def _work_shares(tallies) -> dict:
    """The boards' link checks by kind of search and outcome, summed, and each one's share."""
    total: dict[str, int] = {}
    for tally in tallies:
        for key, checks in tally.items():
            total[key] = total.get(key, 0) + checks
    whole = sum(total.values()) or 1
    return {key: {"checks": checks, "share": round(checks / whole, 3)}
            for key, checks in total.items()}


if __name__ == "__main__":
    main()

"""Benchmark of the walkaround router (`pcbdata.router.walkaround`) on the D2 test boards.

Every connection of every net (pad i to pad i+1, through a via next to the pad when the pads
share no layer) is asked of the router, in net order; found paths become tracks that later nets
avoid (`pcbdata/testing/d2_routes.py`). Reported: per-call median, 90th percentile and maximum wall
time, per method (direct, two-segment, search), connections left open, and the exact
independent legality check of every routed board. Baseline in the same run: the direct and
two-segment tries alone (what `mark_obstacles` would lay, kept only when clear).

    .venv/bin/python bench/bench_walkaround.py [--limit 128] [--json bench/runs/walkaround.json]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
from datetime import UTC, datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def _figures(calls) -> dict:
    times = sorted(c.seconds for c in calls)
    if not times:
        return {"calls": 0}
    return {"calls": len(times), "median_ms": 1e3 * statistics.median(times),
            "p90_ms": 1e3 * times[int(0.9 * (len(times) - 1))], "max_ms": 1e3 * times[-1],
            "total_s": sum(times)}


def _run(boards, **options) -> dict:
    from pcbdata.testing.d2_routes import route_board, violations

    calls, open_total, illegal = [], 0, 0
    for name, board in boards:
        routed, board_calls, open_connections = route_board(name, board, **options)
        calls += board_calls
        open_total += open_connections
        illegal += len(violations(routed))
    by_method = {m: _figures([c for c in calls if c.method == m])
                 for m in sorted({c.method for c in calls})}
    return {"all": _figures(calls), "by_method": by_method, "found": sum(c.ok for c in calls),
            "open_connections": open_total, "violations": illegal,
            "calls_over_1s": sum(c.seconds > 1.0 for c in calls)}


def main() -> int:
    from _measure import machine, report

    from pcbdata.testing.d2_routes import d2_test_boards

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=128)
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()
    boards = d2_test_boards(args.limit)
    load_before = os.getloadavg()
    walkaround = _run(boards)
    direct_only = _run(boards, budget_nodes=0)
    connections = sum(len([p for p in b.pads if p.net == n]) - 1
                      for _, b in boards for n in b.net_names)
    result = {"machine": machine(), "date": datetime.now(UTC).isoformat(timespec="minutes"),
              "load_before": load_before, "load_after": os.getloadavg(), "boards": len(boards),
              "connections": connections, "walkaround": walkaround,
              "baseline_direct_tries_only": direct_only}
    report(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())

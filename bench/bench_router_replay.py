"""The walkaround router of another git revision against this one, on the same recorded calls.

`record` runs scripted episodes in the environment (KiCad, terminal DRC) and saves every
router event (new router, `update`, `with_board`, `route` with its request and path) to a
pickle. `replay` runs those events through this checkout's router and through the router of
`--base` (a git revision, loaded from `git show`), in the same process one after the other,
and reports per-call time medians, the ratio, and whether the paths found are the same, or
longer/bendier.

    .venv/bin/python bench/bench_router_replay.py record --set D3 --config d3-b \
        [--agent scripted-shove] [--limit N] --out calls.pkl
    .venv/bin/python bench/bench_router_replay.py replay calls.pkl --base REV [--json FILE]
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))


def _recording(events: list, board_name: list):
    """Patches WalkaroundRouter so that every event lands in `events`."""
    from pcbdata.router import walkaround

    cls = walkaround.WalkaroundRouter
    init, with_board, update, route = cls.__init__, cls.with_board, cls.update, cls.route

    def rid(router) -> int:
        if not hasattr(router, "_rec_id"):
            router._rec_id = len(events)
        return router._rec_id

    def p_init(self, board, budget_nodes=walkaround.BUDGET_NODES,
               budget_checks=walkaround.BUDGET_CHECKS, budget_seconds=None):
        self._rec_id = len(events)
        events.append(("init", self._rec_id, board, budget_nodes, budget_checks, board_name[0]))
        self._rec_init = True
        init(self, board, budget_nodes, budget_checks, budget_seconds)
        self._rec_init = False

    def p_with_board(self, board):
        other = with_board(self, board)
        other._rec_id = len(events)
        events.append(("with_board", rid(self), other._rec_id, board))
        return other

    def p_update(self, board):
        if not getattr(self, "_rec_init", False) and hasattr(self, "_rec_id"):
            events.append(("update", self._rec_id, board))
        update(self, board)

    def p_route(self, request):
        result = route(self, request)
        events.append(("route", rid(self), request, result.path, board_name[0]))
        return result

    cls.__init__, cls.with_board, cls.update, cls.route = p_init, p_with_board, p_update, p_route


def record(args) -> int:
    import pcbdata.env
    from pcbdata.agents.registry import make_agent
    from pcbdata.runners.rollout import run_episode

    events: list = []
    name = [""]
    _recording(events, name)
    env = pcbdata.env.make(args.set, args.config, split="test", drc="terminal")
    ids = env.unwrapped.source.board_ids[: args.limit]
    for board_id in ids:
        name[0] = board_id
        began = time.perf_counter()
        record_ = run_episode(env, make_agent(args.agent, 0), board_id, 0)
        print(f"{board_id}: {record_['steps']} steps, {time.perf_counter() - began:.1f} s",
              flush=True)
    env.close()
    Path(args.out).write_bytes(pickle.dumps(events, protocol=pickle.HIGHEST_PROTOCOL))
    print(f"{sum(e[0] == 'route' for e in events)} route calls -> {args.out}")
    return 0


def _load_base(rev: str, tmp: Path):
    """The walkaround module of revision `rev`, importable beside this checkout's package."""
    text = subprocess.run(["git", "show", f"{rev}:pcbdata/router/walkaround.py"], cwd=REPO,
                          check=True, capture_output=True, text=True).stdout
    path = tmp / "base_walkaround.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("base_walkaround", path)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules["base_walkaround"] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def _replay(module, events) -> tuple[list, dict]:
    """Route results [(board, seconds, path, stats)] and per-board total seconds."""
    routers: dict[int, object] = {}
    out, per_board = [], {}
    for event in events:
        kind = event[0]
        if kind == "init":
            routers[event[1]] = module.WalkaroundRouter(event[2], event[3], event[4])
        elif kind == "with_board":
            routers[event[2]] = routers[event[1]].with_board(event[3])
        elif kind == "update":
            routers[event[1]].update(event[2])
        else:
            _, rid, request, _, board = event
            began = time.perf_counter()
            result = routers[rid].route(module.RouteRequest(**request.__dict__))
            seconds = time.perf_counter() - began
            out.append((board, seconds, result.path, result.stats))
            per_board[board] = per_board.get(board, 0.0) + seconds
    return out, per_board


def _length(path) -> float:
    from pcbdata.router.geometry import octilinear_length

    return sum(octilinear_length(a, b) for a, b in zip(path, path[1:]))


def _compare(base: list, ours: list) -> dict:
    from pcbdata.router.geometry import bends

    same = longer = bendier = lost = gained = 0
    for (_, _, p0, _), (_, _, p1, _) in zip(base, ours):
        if p0 is None or p1 is None:
            lost += p0 is not None and p1 is None
            gained += p0 is None and p1 is not None
            same += p0 is None and p1 is None
            continue
        if tuple(p0) == tuple(p1):
            same += 1
            continue
        longer += _length(p1) > _length(p0) + 1e-6
        bendier += bends(p1) > bends(p0)
    return {"calls": len(base), "same": same, "longer": longer, "more_bends": bendier,
            "lost": lost, "gained": gained}


def _figures(results: list, per_board: dict) -> dict:
    times = sorted(r[1] for r in results)
    boards = sorted(per_board.values())
    return {"total_s": round(sum(times), 3),
            "call_median_ms": round(1e3 * statistics.median(times), 3) if times else None,
            "call_max_ms": round(1e3 * times[-1], 1) if times else None,
            "board_median_s": round(statistics.median(boards), 3) if boards else None,
            "board_max_s": round(boards[-1], 3) if boards else None}


def replay(args) -> int:
    sys.path.insert(0, str(REPO / "bench"))
    from _measure import machine, report

    from pcbdata.router import walkaround

    events = pickle.loads(Path(args.calls).read_bytes())
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench-replay-") as tmp:
        base = _load_base(args.base, Path(tmp))
        base_results, base_boards = _replay(base, events)
    ours_results, ours_boards = _replay(walkaround, events)
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, check=True,
                          capture_output=True, text=True).stdout.strip()
    b, o = _figures(base_results, base_boards), _figures(ours_results, ours_boards)
    result = {"machine": machine(), "date": datetime.now(UTC).isoformat(timespec="minutes"),
              "load_before": load_before, "load_after": os.getloadavg(),
              "calls_file": Path(args.calls).name, "base": args.base, "ours": head,
              "base_figures": b, "our_figures": o,
              "speedup_total": round(b["total_s"] / max(o["total_s"], 1e-9), 2),
              "per_board_s": {k: [round(base_boards[k], 3), round(ours_boards[k], 3)]
                              for k in sorted(base_boards)},
              "paths": _compare(base_results, ours_results)}
    report(result, args.json)
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record")
    rec.add_argument("--set", required=True)
    rec.add_argument("--config", default="d3-b")
    rec.add_argument("--agent", default="scripted-shove")
    rec.add_argument("--limit", type=int, default=10)
    rec.add_argument("--out", required=True)
    rep = sub.add_parser("replay")
    rep.add_argument("calls")
    rep.add_argument("--base", required=True, help="git revision of the router to compare with")
    rep.add_argument("--json")
    args = parser.parse_args()
    return record(args) if args.command == "record" else replay(args)


if __name__ == "__main__":
    sys.exit(main())

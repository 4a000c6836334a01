"""Benchmark of push_n_shove: how often it routes where walkaround could not, and what it does
to the scripted agent's CP.

Per board, two episodes (DRC at the end; the agents do not read the DRC): the scripted agent
(walkaround only) and the same agent with the push_n_shove fallback (`scripted-shove`: every
`finish` that walkaround could not route is tried once more in push_n_shove mode). Counts the
fallback's tries, its successes (tracks of other nets moved, or a path found without moving
any) and the undone ones; then CP @1 of both agents' boards by `pcbdata eval`.

    .venv/bin/python bench/bench_shove.py [--config d2] [--set SET] [--limit N]
        [--json bench/runs/shove.json]
D2 configs are generated when --set is not given; D3 needs --set (a `pcbdata build d3` output).

`--router-only` (D2 levels, no KiCad): close to the protocol of `bench/bench_walkaround.py`
(connections asked in net order, pad i to pad i+1, each path committed; here only pads that
share a layer, on the first shared layer, no via); for each connection that walkaround cannot
route, push_n_shove is asked the same request on the same board (not committed, so the
walkaround protocol is unchanged).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from collections import Counter
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def _episodes(root: Path, config: str, limit: int, shove: bool, runs: Path) -> dict:
    import pcbdata.env
    from pcbdata.agents.scripted import ScriptedAgent
    from pcbdata.env.types import FINISH, PUSH_N_SHOVE

    env = pcbdata.env.make(root, config, split="test", drc="terminal")
    tries, times = Counter(), []
    for board_id in env.unwrapped.source.board_ids[:limit]:
        agent, began = ScriptedAgent(seed=0, shove=shove), time.perf_counter()
        obs, info = env.reset(options={"board_id": board_id})
        while True:
            act = agent.act(obs, info)
            if agent.done:
                env.unwrapped.finish_episode()  # the final DRC, as every runner ends early
                break
            obs, _, terminated, truncated, info = env.step(act)
            if act["type"] == FINISH and act["mode"] == PUSH_N_SHOVE:
                tries.update(_outcome(info["router"]))
            if terminated or truncated:
                break
        times.append(time.perf_counter() - began)
        (runs / board_id).mkdir(parents=True, exist_ok=True)
        env.unwrapped.save(runs / board_id / "0.kicad_pcb")
    env.close()
    return {"tries": dict(tries), "median_episode_s": statistics.median(times)}


def _outcome(router: dict) -> list[str]:
    if router["ok"]:
        moved = router["stats"].get("method") == "shove"
        return ["tries", "routed", "routed_moving_tracks" if moved else "routed_without_moving"]
    return ["tries", "undone" if "undone" in router["reason"] else "failed"]


def _router_only(config: str, limit: int) -> dict:
    from pcbdata.generators.d2 import D2Generator
    from pcbdata.router.geometry import geometry_from_board
    from pcbdata.router.requests import RouteRequest
    from pcbdata.router.shove import plan
    from pcbdata.router.walkaround import WalkaroundRouter
    from pcbdata.sets.presets import level
    from pcbdata.testing import d2_routes

    level = level("d2", config.removeprefix("d2-") if config != "d2" else "default")
    generator = D2Generator(level.params)
    counts: Counter = Counter()
    for index in range(limit):
        board = generator.generate(level.seed, "test", index).board
        board = replace(board, tracks=list(board.tracks), vias=list(board.vias))
        router = WalkaroundRouter(geometry_from_board(board))
        for net in board.net_names:
            pads = [p for p in board.pads if p.net == net]
            for a, b in zip(pads, pads[1:]):
                shared = [la for la in d2_routes.LAYERS
                          if la in d2_routes.pad_layers(a) and la in d2_routes.pad_layers(b)]
                for layer in shared[:1]:
                    request = RouteRequest(net, layer, (a.x, a.y), (b.x, b.y),
                                           board.rules.track_width, board.rules.clearance)
                    found = router.route(request)
                    counts["connections"] += 1
                    if found.path is not None:
                        d2_routes._commit(board, router, net, layer, found.path)
                        continue
                    counts["walkaround_failed"] += 1
                    done = plan(router, request)
                    counts["shove_routed" if done.path is not None else "shove_failed"] += 1
                    counts["moved_tracks"] += len(done.removed)
    return dict(counts)


def _write_set(root: Path, config: str, limit: int) -> None:
    from pcbdata.testing.sets import write_set

    write_set(root, config, "test", limit)


def main() -> int:
    from _measure import machine, report

    from pcbdata.evaluator.runs import evaluate_set

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="d2")
    parser.add_argument("--set", help="a built set holding <config>/test (default: generated)")
    parser.add_argument("--limit", type=int, default=128)
    parser.add_argument("--json", help="write the figures here")
    parser.add_argument("--router-only", action="store_true",
                        help="D2 levels: walkaround then push_n_shove on the same requests, "
                             "without KiCad")
    args = parser.parse_args()
    if args.router_only:
        print(json.dumps({"config": args.config, "boards": args.limit,
                          **_router_only(args.config, args.limit)}, sort_keys=True))
        return 0
    result: dict = {"machine": machine(), "config": args.config, "limit": args.limit,
                    "date": datetime.now(UTC).isoformat(timespec="minutes"),
                    "load_before": os.getloadavg()}
    with tempfile.TemporaryDirectory(prefix="bench-shove-") as tmp:
        root = Path(args.set) if args.set else Path(tmp) / "set"
        if not args.set:
            if not args.config.startswith("d2"):
                parser.error("--set is needed for D1 and D3 configs")
            _write_set(root, args.config, args.limit)
        for name, shove in (("scripted", False), ("scripted-shove", True)):
            runs = Path(tmp) / name
            figures = _episodes(root, args.config, args.limit, shove, runs)
            report = evaluate_set(root, args.config, "test", Path(tmp) / f"report-{name}",
                                  runs=runs, k=1, workers=2, progress=False, limit=args.limit)
            figures["eval"] = {key: report["summary"][key]
                               for key in ("cp", "cp_strict", "pot", "rout", "drv", "wl", "via")}
            result[name] = figures
            print(name, json.dumps(figures, sort_keys=True), flush=True)
    result["load_after"] = os.getloadavg()
    report(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())

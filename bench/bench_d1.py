"""D1 routing figures: an agent's CP and Rout. @k on the D1 test sets, scored by `pcbdata eval`.

Writes the first N test boards of each D1 grid from the generator (the same bytes `pcbdata build
d1` writes), rolls the agent out k times per board with `pcbdata rollout`'s library call (2
workers by default), scores them with `pcbdata eval`'s (`evaluate_set`, CP, Pot. and Rout. of
the best of k; Pot. also in the paper's D1 convention, `--convention d1-published`) and prints
one row per grid: boards, CP, both Pot., Rout., mean wall time per episode. The baseline
(`--baseline`, default the scripted agent) runs in the same call on the same boards. Also
counted: boards with a net walled in by other pads (`D1Grid.walled_nets`), which no agent can
complete.

    python bench/bench_d1.py --limit 16 --k 5
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

GRIDS = (10, 50, 100, 200, 500)
AGENT = "pcbdata.agents.d1:D1Agent"


def _write(root: Path, config: str, limit: int) -> None:
    from pcbdata.testing.sets import write_set

    if not (root / config / "test").is_dir():
        write_set(root, config, "test", limit)


def _walled_boards(config: str, limit: int) -> int:
    """Boards with a net that no agent can join (a pad walled in by other pads)."""
    from pcbdata.agents.d1 import D1Grid
    from pcbdata.sets.configs import get_config

    spec = get_config(config)
    generator, count = spec.generator(), 0
    for index in range(limit):
        board = generator.generate(spec.seed, "test", index).board
        pitch = 2 * board.pads[0].size
        pads: dict = {}
        for pad in board.pads:
            cell = (round(pad.x / pitch - 0.75), round(pad.y / pitch - 0.75))
            pads.setdefault(pad.net, []).append(cell)
        size = round((board.width - 0.5 * pitch) / pitch)
        count += bool(D1Grid.of(pitch / 1e6, size, pads).walled_nets())
    return count


def _grid(root: Path, work: Path, config: str, agent: str, args) -> dict:
    from pcbdata.evaluator.metrics import CONVENTIONS
    from pcbdata.evaluator.runs import evaluate_set
    from pcbdata.runners.rollout import run_rollouts

    name = agent.rsplit(":", 1)[-1]
    runs, report = work / f"runs-{name}-{config}", work / f"report-{name}-{config}"
    began = time.perf_counter()
    run_rollouts(root, config, "test", agent, args.k, runs, args.workers, limit=args.limit,
                 env_options={"drc": args.drc}, log=lambda line: None)
    wall = time.perf_counter() - began
    times = [json.loads(p.read_text())["time_s"] for p in runs.glob("*/*.json")]
    scored = evaluate_set(root, config, "test", report, runs=runs, k=args.k,
                          workers=args.workers, progress=False, limit=args.limit)
    s = scored["summary"]
    published = evaluate_set(root, config, "test", work / f"{report.name}-d1-published",
                             runs=runs, k=args.k, workers=args.workers, progress=False,
                             limit=args.limit, weights=CONVENTIONS["d1-published"])["summary"]
    return {"config": config, "agent": name, "boards": args.limit,
            "walled_in": _walled_boards(config, args.limit) if config.startswith("d1-") else "-",
            "cp": s["cp"], "pot": s["pot"], "pot_d1_published": published["pot"],
            "rout": s["rout"], "episode_s": statistics.mean(times) if times else None,
            "rollouts_wall_s": wall}


def _table(rows: list[dict], k: int) -> str:
    lines = [f"| agent | grid | boards | walled in | CP @{k} (%) | Pot. @{k} | Pot. @{k} "
             f"(d1-published) | Rout. @{k} | s / episode |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['agent']} | {r['config']} | {r['boards']} | {r['walled_in']} | "
                     f"{100 * r['cp']:.1f} | {r['pot']:.2f} | {r['pot_d1_published']:.2f} | "
                     f"{r['rout']:.3f} | {r['episode_s']:.3f} |")
    return "\n".join(lines)


def main() -> int:
    from _measure import machine

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=16, help="test boards per grid")
    parser.add_argument("--k", type=int, default=5, help="rollouts per board (CP @k)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--drc", default="terminal",
                        help="the environment's drc option: 'terminal' (default; neither agent "
                             "reads the DRC, so the boards are the same as with 'step') or 'step'")
    parser.add_argument("--grids", default=",".join(map(str, GRIDS)),
                        help="D1 grid sizes, or config names (d2: the 'not worse' check)")
    parser.add_argument("--agent", default=AGENT)
    parser.add_argument("--baseline", default="scripted", help="'' for none")
    parser.add_argument("--keep", help="keep boards and runs in this folder")
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()
    configs = [f"d1-g{g}" if g.isdigit() else g for g in args.grids.split(",")]
    agents = [a for a in (args.baseline, args.agent) if a]
    load_before = Path("/proc/loadavg").read_text().strip()
    with tempfile.TemporaryDirectory(prefix="bench-d1-") as tmp:
        work = Path(args.keep) if args.keep else Path(tmp)
        root = work / "set"
        rows = []
        for config in configs:
            _write(root, config, args.limit)
            for agent in agents:
                rows.append(_grid(root, work, config, agent, args))
                print(_table(rows[-1:], args.k).splitlines()[-1], flush=True)
    result = {"machine": machine(), "date": datetime.now(UTC).isoformat(timespec="minutes"),
              "load_before": load_before, "load_after": Path("/proc/loadavg").read_text().strip(),
              "k": args.k, "workers": args.workers, "rows": rows}
    print(_table(rows, args.k))
    print(f"{result['date']}  {result['machine']}  load before {load_before}, "
          f"after {result['load_after']}  (cpus: {os.cpu_count()})")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Episode times of one agent over a built set's test split, in one process: one episode per
board (reset to end, as `pcbdata rollout` times it), the median wall time and the steps in all.

Made for `farm-bench --vs`, two checkouts side by side in one run (the checkout is the one on
PYTHONPATH), e.g. the negotiated agent with DRC after every step, this tree against an older
one:

    farm-bench -n 3 --timeout 800 \\
      --vs "sh -c 'PYTHONPATH=OLD exec .venv/bin/python bench/bench_episode_times.py SET \\
            --config d3-a --drc step >> old.txt'" \\
      -- sh -c 'PYTHONPATH=. exec .venv/bin/python bench/bench_episode_times.py SET \\
            --config d3-a --drc step >> new.txt'

`--parts` also splits the episodes' time into the agent's `act` calls (a planning agent's plan
included), the environment's `step` calls and its `reset` calls, and counts the steps by type.
"""
from __future__ import annotations

import argparse
import statistics
import time
from collections import Counter


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("set", help="a built set")
    parser.add_argument("--config", default="d3-a")
    parser.add_argument("--split", default="test")
    parser.add_argument("--agent", default="negotiated", help="an --agent of pcbdata rollout")
    parser.add_argument("--drc", default="step", choices=("step", "terminal"))
    parser.add_argument("--limit", type=int, default=None, help="only the first N boards")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--parts", action="store_true",
                        help="split the time into act, step and reset calls")
    args = parser.parse_args()

    import pcbdata
    import pcbdata.env
    from pcbdata.agents.registry import make_agent
    from pcbdata.core.tree import list_instances
    from pcbdata.env.types import ACTION_TYPES
    from pcbdata.runners.rollout import run_episode

    boards = [b for b, _ in list_instances(args.set, args.config, args.split)][:args.limit]
    env = pcbdata.env.make(args.set, args.config, split=args.split, drc=args.drc)
    times, steps, clean = [], 0, 0
    parts: Counter = Counter()
    kinds: Counter = Counter()
    if args.parts:
        _timed(env.unwrapped, "step", parts, kinds, ACTION_TYPES)
        _timed(env.unwrapped, "reset", parts)
    try:
        for board_id in boards:
            agent = make_agent(args.agent, args.seed, None)
            if args.parts:
                _timed(agent, "act", parts)
            record = run_episode(env, agent, board_id, args.seed)
            times.append(record["time_s"])
            steps += record["steps"]
            clean += record["unconnected"] == 0 and record["drv"] == 0
    finally:
        env.close()
    print(f"{pcbdata.__file__}: {args.agent} on {len(boards)} {args.config} {args.split} "
          f"boards, DRC {args.drc}: median episode {statistics.median(times):.4f} s, "
          f"{steps} steps, {clean} clean")
    if args.parts:
        print("seconds: " + ", ".join(f"{k} {v:.3f}" for k, v in sorted(parts.items()))
              + f"; all episodes {sum(times):.3f}")
        print("steps: " + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())))


def _timed(owner, name: str, parts: Counter, kinds: Counter | None = None,
           types: tuple[str, ...] = ()) -> None:
    """Wraps `owner.name` so that its calls add their wall time to `parts[name]` (and, for
    `step`, count the actions by type in `kinds`)."""
    inner = getattr(owner, name)

    def timed(*args, **kwargs):
        began = time.perf_counter()
        try:
            return inner(*args, **kwargs)
        finally:
            parts[name] += time.perf_counter() - began
            if kinds is not None and args and isinstance(args[0], dict):
                kinds[types[int(args[0]["type"])]] += 1

    setattr(owner, name, timed)


if __name__ == "__main__":
    main()

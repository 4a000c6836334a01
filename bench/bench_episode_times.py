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
"""
from __future__ import annotations

import argparse
import statistics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("set", help="a built set")
    parser.add_argument("--config", default="d3-a")
    parser.add_argument("--split", default="test")
    parser.add_argument("--agent", default="negotiated", help="an --agent of pcbdata rollout")
    parser.add_argument("--drc", default="step", choices=("step", "terminal"))
    parser.add_argument("--limit", type=int, default=None, help="only the first N boards")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    import pcbdata
    import pcbdata.env
    from pcbdata.agents.registry import make_agent
    from pcbdata.core.tree import list_instances
    from pcbdata.runners.rollout import run_episode

    boards = [b for b, _ in list_instances(args.set, args.config, args.split)][:args.limit]
    env = pcbdata.env.make(args.set, args.config, split=args.split, drc=args.drc)
    times, steps, clean = [], 0, 0
    try:
        for board_id in boards:
            record = run_episode(env, make_agent(args.agent, args.seed, None), board_id,
                                 args.seed)
            times.append(record["time_s"])
            steps += record["steps"]
            clean += record["unconnected"] == 0 and record["drv"] == 0
    finally:
        env.close()
    print(f"{pcbdata.__file__}: {args.agent} on {len(boards)} {args.config} {args.split} "
          f"boards, DRC {args.drc}: median episode {statistics.median(times):.4f} s, "
          f"{steps} steps, {clean} clean")


if __name__ == "__main__":
    main()

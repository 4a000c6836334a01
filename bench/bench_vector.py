"""Benchmark of vectorised RL use: steps per second of vector environments against one.

`pcbdata.env.wrappers.rl.make_vector_env` (Gymnasium's AsyncVectorEnv over spawned workers, one
KiCad engine each) for 1, 2 and 4 environments, against one unwrapped environment stepped
serially in this process (the baseline) and one wrapped environment in this process (the
wrapper's own cost).

A masked random policy (uniform over allowed types, then over that type's allowed index and
mode: `pcbdata.env.wrappers.rl.sample_action`, seed 0; the baseline and the one-environment runs
take the same actions, so they play the same episodes), D2 boards generated on the fly, episodes of
at most `--max-steps` steps (finished episodes reset inside the timed run, as in training), DRC
after every copper change and DRC at the end only. Timing starts after the first reset (the
KiCad workers' start-up is not counted); each row is the fastest of `--repeat` runs.

    .venv/bin/python bench/bench_vector.py [--steps 400] [--sizes 1,2,4] [--out bench/runs]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench._measure import machine  # noqa: E402


def _baseline(options: dict, steps: int) -> tuple[float, float]:
    """Seconds for `steps` steps of one unwrapped RoutingEnv, serially, in this process. Its
    actions are the wrapped runs' draws (`sample_action` on the joint masks made from the
    environment's own masks, same seed): the same episodes, so the difference is the cost."""
    from pcbdata.env.env import RoutingEnv
    from pcbdata.env.wrappers.rl import env_action, index_size, joint_masks, sample_action

    env = RoutingEnv(**options)
    k = index_size(env.options)
    rng = np.random.default_rng(0)
    try:
        _, info = env.reset(seed=0)
        began, total = time.perf_counter(), 0.0
        for _ in range(steps):
            index, mode = joint_masks(info["action_mask"], k)
            action = sample_action({"index_mask": index, "mode_mask": mode}, rng)
            _, reward, terminated, truncated, info = env.step(env_action(action))
            total += reward
            if terminated or truncated:
                _, info = env.reset()
        return time.perf_counter() - began, total
    finally:
        env.close()


def _wrapped(options: dict, steps: int) -> tuple[float, float]:
    """(Seconds, summed reward) of `steps` steps of one RLWrapper-wrapped environment in this
    process."""
    from pcbdata.env.wrappers.rl import make_rl_env, sample_action

    env = make_rl_env(**options)
    rng = np.random.default_rng(0)
    try:
        obs, _ = env.reset(seed=0)
        began, total = time.perf_counter(), 0.0
        for _ in range(steps):
            obs, reward, terminated, truncated, _ = env.step(sample_action(obs, rng))
            total += float(reward)
            if terminated or truncated:
                obs, _ = env.reset()
        return time.perf_counter() - began, total
    finally:
        env.close()


def _vector(options: dict, n: int, steps: int) -> tuple[float, float]:
    """(Seconds, summed reward) of N spawned wrapped environments until they made N * steps
    steps. Gymnasium resets a finished environment on its next step (its action is ignored):
    that step is not counted and draws no action, so one environment plays the baseline's
    episodes."""
    from pcbdata.env.wrappers.rl import make_vector_env, sample_action

    options = dict(options)
    envs = make_vector_env(options.pop("config"), n, **options)
    rng = np.random.default_rng(0)
    idle = np.zeros(3, dtype=np.int64)
    try:
        obs, _ = envs.reset(seed=list(range(n)))
        ended = np.zeros(n, dtype=bool)
        began, total, done = time.perf_counter(), 0.0, 0
        while done < n * steps:
            actions = np.stack([idle if ended[i] else
                                sample_action({k: v[i] for k, v in obs.items()}, rng)
                                for i in range(n)])
            done += int((~ended).sum())
            obs, reward, terminated, truncated, _ = envs.step(actions)
            total += float(reward.sum())
            ended = terminated | truncated
        return time.perf_counter() - began, total
    finally:
        envs.close()


def _best(run, repeat: int) -> tuple[float, float]:
    """The fastest of `repeat` runs (the machine is shared: slower runs waited for others)."""
    results = [run() for _ in range(repeat)]
    return min(seconds for seconds, _ in results), results[0][1]


def _rows(drc: str, options: dict, steps: int, sizes: list[int], repeat: int) -> list[dict]:
    runs = [("unwrapped, in process (baseline)", 1, lambda: _baseline(options, steps)),
            ("RLWrapper, in process", 1, lambda: _wrapped(options, steps))]
    runs += [(f"make_vector_env, {n} spawned", n, lambda n=n: _vector(options, n, steps))
             for n in sizes]
    _baseline(options, 20)  # warm-up, not timed: lazy imports, first router and DRC in-process
    rows = []
    for name, n, run in runs:
        seconds, reward = _best(run, repeat)
        rows.append({"drc": drc, "setting": name, "envs": n, "steps": n * steps,
                     "seconds": seconds, "steps_per_s": n * steps / seconds,
                     "reward_sum": reward})
        print(f"{drc:8s} {name:34s} {n * steps:6d} steps {seconds:7.2f} s "
              f"{n * steps / seconds:7.1f} steps/s, rewards {reward:.4f}", flush=True)
    base = rows[0]["steps_per_s"]
    for row in rows:
        row["vs_baseline"] = row["steps_per_s"] / base
    return rows


def _markdown(result: dict) -> str:
    lines = [f"Machine: {result['machine']}; {result['date']}; load average before "
             f"{result['load_before']}, after {result['load_after']}.", "",
             "| DRC | setting | envs | steps | s | steps/s | x baseline |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
    for r in result["rows"]:
        lines.append(f"| {r['drc']} | {r['setting']} | {r['envs']} | {r['steps']} | "
                     f"{r['seconds']:.1f} | {r['steps_per_s']:.1f} | {r['vs_baseline']:.2f} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=400, help="steps per environment")
    parser.add_argument("--sizes", default="1,2,4", help="numbers of vectorised environments")
    parser.add_argument("--drc", default="step,terminal", help="step, terminal or both")
    parser.add_argument("--max-steps", type=int, default=100, help="episode length limit")
    parser.add_argument("--count", type=int, default=32, help="generated D2 test boards")
    parser.add_argument("--repeat", type=int, default=2, help="runs per row; the fastest counts")
    parser.add_argument("--out", default="bench/runs", help="folder of vector.json/.md")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    load_before = os.getloadavg()
    rows = []
    for drc in args.drc.split(","):
        options = {"config": "d2", "split": "test", "count": args.count, "drc": drc,
                   "max_steps": args.max_steps}
        rows += _rows(drc, options, args.steps, sizes, args.repeat)
    result = {"machine": machine(), "date": datetime.now(UTC).isoformat(timespec="minutes"),
              "load_before": [round(v, 2) for v in load_before],
              "load_after": [round(v, 2) for v in os.getloadavg()],
              "cpus": os.cpu_count(), "steps_per_env": args.steps, "max_steps": args.max_steps,
              "repeat": args.repeat,
              "rows": rows}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "vector.json").write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    (out / "vector.md").write_text(_markdown(result))
    print(_markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())

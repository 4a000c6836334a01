"""Benchmark: RLlib PPO (`examples/rllib_ppo.py`) for a few iterations on a Ray cluster.

Starts a local Ray cluster with `--cpus` CPUs (or joins `--address`), builds the example's PPO
(`--env-runners` EnvRunners, each with one environment and its KiCad worker; the learner in
this driver) and trains `--iterations` iterations of `--train-batch` env steps. Per iteration:
wall seconds, env steps sampled, env steps per second (of the whole iteration: sampling and
learning), episodes ended and their mean return; the first iteration's time split between
sampling and the learner (RLlib's timers); the start-up time (Ray, EnvRunners, model); and
the steps per second of the same environment stepped alone with random actions (no Ray, no
learning). `episode_return_mean` is RLlib's: the mean over the last (up to) 100
episodes so far, not only this iteration's. Figures in docs/ray.md ("RLlib").

    .venv/bin/python bench/bench_rllib.py --iterations 3 --train-batch 512 --json bench-rllib.json
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from datetime import UTC, datetime
from importlib.metadata import version
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "examples"))
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

import rllib_ppo  # noqa: E402
from _measure import machine, report  # noqa: E402
from rllib_ppo import ENV_CONFIG, ENV_ID, make_env, ppo_config  # noqa: E402


def iteration_figures(result: dict, seconds: float) -> dict:
    runners = result.get("env_runners", {})
    steps = int(runners.get("num_env_steps_sampled", 0))
    mean = runners.get("episode_return_mean")
    return {"seconds": round(seconds, 2), "env_steps": steps,
            "env_steps_per_s": round(steps / seconds, 1),
            "episodes": int(runners.get("num_episodes", 0)),
            "episode_return_mean": None if mean is None else round(float(mean), 4)}


def env_alone(steps: int, seed: int) -> float:
    """Env steps per second of the same wrapped environment with uniform random actions, in
    this process, no Ray: what RLlib's figures compare with."""
    env = make_env(ENV_CONFIG)
    env.action_space.seed(seed)
    try:
        env.reset(seed=seed)
        began = time.perf_counter()
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if terminated or truncated:
                env.reset()
        return steps / (time.perf_counter() - began)
    finally:
        env.close()


def first_iteration_split(result: dict) -> dict:
    """Where the first iteration's time went, from RLlib's timers. They are moving averages, so
    only the first iteration's values are that iteration's own."""
    timers = result.get("timers", {})
    names = {"sampling_s": "env_runner_sampling_timer", "learner_update_s": "learner_update_timer",
             "weight_sync_s": "synch_weights"}
    return {key: round(float(timers[name]), 2) for key, name in names.items() if name in timers}


def run(args) -> dict:
    import ray
    from ray import cloudpickle

    # The env creator travels by value: `examples/` is not importable on the EnvRunners.
    cloudpickle.register_pickle_by_value(rllib_ppo)
    load_before = os.getloadavg()
    alone = env_alone(args.train_batch, args.seed)
    start = time.perf_counter()
    if args.address:
        ray.init(address=args.address)
    else:
        ray.init(num_cpus=args.cpus, include_dashboard=False)
    algo = ppo_config(args.env_runners, args.train_batch, seed=args.seed).build_algo()
    figures: dict = {
        "machine": machine(), "date": datetime.now(UTC).isoformat(timespec="minutes"),
        "load_before": [round(v, 2) for v in load_before],
        "versions": {name: version(name) for name in ("ray", "torch", "gymnasium")},
        "env_id": ENV_ID, "env_config": ENV_CONFIG,
        "cluster": args.address or f"local, {args.cpus} CPUs",
        "env_runners": args.env_runners, "train_batch": args.train_batch,
        "env_alone_steps_per_s": round(alone, 1),
        "startup_s": round(time.perf_counter() - start, 2), "iterations": []}
    try:
        for _ in range(args.iterations):
            began = time.perf_counter()
            result = algo.train()
            figures["iterations"].append(iteration_figures(result, time.perf_counter() - began))
            figures.setdefault("first_iteration_split", first_iteration_split(result))
            print(figures["iterations"][-1], flush=True)
    finally:
        algo.stop()
        ray.shutdown()
    figures["train_s"] = round(sum(i["seconds"] for i in figures["iterations"]), 2)
    figures["load_after"] = [round(v, 2) for v in os.getloadavg()]
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--address", help="an existing Ray cluster (default: a new local one)")
    parser.add_argument("--cpus", type=int, default=2, help="CPUs of the local cluster")
    parser.add_argument("--iterations", type=int, default=3)
    parser.add_argument("--env-runners", type=int, default=1)
    parser.add_argument("--train-batch", type=int, default=512, help="env steps per iteration")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    report(run(args), args.json)


if __name__ == "__main__":
    main()

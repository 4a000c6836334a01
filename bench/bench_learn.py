"""Benchmark of the learned router's training loop: environment steps per second with
`make_vector_env` (spawned workers, D2 train boards generated on the fly) for
  - masked random actions (`sample_action`): the environment alone (the baseline);
  - the set policy acting (rows compacted, one forward pass per step for all environments);
  - the policy acting and learning (PPO update after each rollout, as `pcbdata train` does);
and the rows the network reads per observation (net and candidate blocks plus the valid rows of
the other families) against the wrapper's fixed table.

    .venv/bin/python bench/bench_learn.py [--envs 2] [--steps 64] [--updates 2] [--out FILE]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench._measure import machine, report  # noqa: E402


def _random(envs, n: int, steps: int) -> float:
    from pcbdata.env.wrappers.rl import sample_action

    rng = np.random.default_rng(0)
    obs, _ = envs.reset(seed=list(range(n)))
    began = time.perf_counter()
    for _ in range(steps):
        acts = np.stack([sample_action({k: v[i] for k, v in obs.items()}, rng)
                         for i in range(n)])
        obs, *_ = envs.step(acts)
    return n * steps / (time.perf_counter() - began)


def _policy(envs, s, updates: int, learn: bool) -> tuple[float, list[int]]:
    import torch

    from pcbdata.learn import train as training
    from pcbdata.learn.policy import SetPolicy, device

    torch.manual_seed(0)
    dev = device()
    policy = SetPolicy(dim=s.dim).to(dev)
    opt = torch.optim.Adam(policy.parameters(), lr=s.lr_ppo)
    steps, rows, began = 0, [], time.perf_counter()
    for update in range(1, updates + 1):
        ro, last, _ = training.collect(policy, envs, s, update, dev)
        if learn:
            training.ppo_update(policy, opt, ro, last, s, update, dev)
        steps += int(np.stack(ro.live).sum())
        rows += [len(o["x"]) for step in ro.obs for o in step]
    return steps / (time.perf_counter() - began), rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=2)
    ap.add_argument("--steps", type=int, default=64, help="steps per environment and update")
    ap.add_argument("--updates", type=int, default=2)
    ap.add_argument("--out", help="JSON file for the figures")
    args = ap.parse_args(argv)
    from pcbdata.env.wrappers.rl import make_vector_env
    from pcbdata.learn.train import Settings, env_options

    s = replace(Settings(), envs=args.envs, rollout_steps=args.steps)
    envs = make_vector_env(s.config, s.envs, **env_options(s, "train", s.train_boards))
    try:
        table_rows = int(envs.single_observation_space["entities"].shape[0])
        random_rate = _random(envs, s.envs, args.steps * args.updates)
        acting, rows = _policy(envs, s, args.updates, learn=False)
        learning, _ = _policy(envs, s, args.updates, learn=True)
    finally:
        envs.close()
    report({"machine": machine(), "load_before": os.getloadavg()[0], "envs": s.envs,
            "steps_per_env_and_update": args.steps, "updates": args.updates,
            "table_rows": table_rows, "network_rows_mean": float(np.mean(rows)),
            "network_rows_max": int(np.max(rows)), "random_steps_per_s": random_rate,
            "policy_steps_per_s": acting, "policy_learning_steps_per_s": learning}, args.out)


if __name__ == "__main__":
    main()

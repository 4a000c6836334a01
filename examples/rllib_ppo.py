"""PPO from RLlib on the routing environment's RL wrapper, through its Gymnasium id, on Ray.

    pip install 'ray[rllib]' torch            # RLlib and a deep-learning framework
    python examples/rllib_ppo.py --check-env  # the wrapped environment alone, no RLlib
    python examples/rllib_ppo.py --env-runners 1 --iterations 3 [--address HEAD_IP:6379]

Each RLlib EnvRunner (a Ray actor, on whichever node Ray places it) makes its environment with
`make_env` below: `gym.make("pcbdata/RouteRL-d2-v2", ...)` (the RL wrapper, docs/env_rl.md),
D2 boards generated on the fly (no built set needed), KiCad's DRC only at the end of an episode,
short episodes. Each EnvRunner owns one KiCad worker process, started at its first reset.
The learner (RLlib's new API stack, PPO, default MLP model) trains in the driver on what the
EnvRunners send back. `bench/bench_rllib.py` times this loop; its figures are in docs/ray.md
("RLlib").

What this example ignores: RLlib's default model takes a flat Box observation, so the wrapper's
Dict observation is flattened (Gymnasium's `FlattenObservation`, then float32) and the masks in
it (`action_mask`, `index_mask`, `mode_mask`) are only more inputs; nothing masks the policy's
logits. The action stays the wrapper's `MultiDiscrete([7, K, 3])`, drawn as three independent
parts, so many actions are masked ones: each is a rejected no-op that uses up a step (the
reason in `info["rejected"]`), and PPO can only learn to avoid them slowly. No entity structure
either: the MLP sees the entity table as one long vector. It shows RLlib's PPO training on the
environment, not a good router. pcbdata's own learner (`pcbdata train`,
docs/learn.md) is the intended one: masked, autoregressive actions over the entity table.
"""
from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

ENV_ID = "pcbdata/RouteRL-d2-v2"
#: Options of every EnvRunner's environment (docs/env.md): 1000 train boards generated on the
#: fly, short episodes, KiCad's DRC only at the end of an episode (the cheaper setting).
ENV_CONFIG = {"split": "train", "count": 1000, "max_steps": 64, "drc": "terminal"}


def flat_observations(env: gym.Env) -> gym.Env:
    """The Dict observation as one float32 vector, for RLlib's default models."""
    flat = gym.wrappers.FlattenObservation(env)
    low, high = flat.observation_space.low, flat.observation_space.high  # type: ignore[attr-defined]
    space = gym.spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)
    return gym.wrappers.TransformObservation(flat, lambda obs: obs.astype(np.float32), space)


def make_env(env_config) -> gym.Env:
    """RLlib's env creator. It runs in each EnvRunner's process, so it imports `pcbdata.env`
    there (Gymnasium's registry is per process; the import registers the ids). `env_config` is
    RLlib's EnvContext: a dict of `ENV_CONFIG` (with worker_index as an attribute)."""
    import pcbdata.env  # noqa: F401 - registers pcbdata/RouteRL-*-v2 in this process

    return flat_observations(gym.make(ENV_ID, **dict(env_config)))


def check_env(steps: int = 20) -> dict:
    """Without RLlib: the wrapped environment resets and steps with sampled actions."""
    env = make_env(ENV_CONFIG)
    try:
        obs, _ = env.reset(seed=0)
        if not env.observation_space.contains(obs):
            raise AssertionError("observation outside its space")
        total, rejected = 0.0, 0
        for _ in range(steps):
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            total += float(reward)
            rejected += bool(info["rejected"])
            if terminated or truncated:
                obs, _ = env.reset()
        figures = {"observation": list(env.observation_space.shape),
                   "dtype": str(env.observation_space.dtype), "action": str(env.action_space),
                   "steps": steps, "rejected": rejected, "reward": round(total, 3)}
        print("ok:", figures)
        return figures
    finally:
        env.close()


def ppo_config(env_runners: int, train_batch: int, seed: int = 0):
    """RLlib's PPO (new API stack) on `ENV_ID`, registered with Ray Tune's registry under the
    environment's own id: RLlib ships the creator to every EnvRunner."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.tune.registry import register_env

    register_env(ENV_ID, make_env)
    return (
        PPOConfig()
        .environment(ENV_ID, env_config=ENV_CONFIG)
        .env_runners(num_env_runners=env_runners, num_envs_per_env_runner=1,
                     rollout_fragment_length="auto")
        .learners(num_learners=0)  # the learner trains in the driver
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[64, 64]))
        .training(lr=3e-4, train_batch_size_per_learner=train_batch,
                  minibatch_size=min(128, train_batch), num_epochs=4)
        .debugging(seed=seed)
    )


def train(address: str | None, env_runners: int, iterations: int, train_batch: int) -> None:
    import ray

    ray.init(address=address)
    algo = ppo_config(env_runners, train_batch).build_algo()
    try:
        for iteration in range(iterations):
            runners = algo.train().get("env_runners", {})
            print(f"iteration {iteration}: env steps {runners.get('num_env_steps_sampled')}, "
                  f"episodes {runners.get('num_episodes')}, episode return mean "
                  f"{runners.get('episode_return_mean')}", flush=True)
    finally:
        algo.stop()
        ray.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--address", help="Ray cluster (default: RAY_ADDRESS, else local)")
    parser.add_argument("--env-runners", type=int, default=1, help="RLlib EnvRunners (actors)")
    parser.add_argument("--iterations", type=int, default=3, help="training iterations")
    parser.add_argument("--train-batch", type=int, default=512,
                        help="env steps per training iteration")
    parser.add_argument("--check-env", action="store_true",
                        help="only make the wrapped environment and step it (no RLlib needed)")
    args = parser.parse_args()
    if args.check_env:
        check_env()
    else:
        train(args.address, args.env_runners, args.iterations, args.train_batch)


if __name__ == "__main__":
    main()

"""PPO from RLlib on the routing environment, through its Gymnasium id, on a Ray cluster.

    pip install 'ray[rllib]' torch            # RLlib needs a deep-learning framework
    python examples/rllib_ppo.py --env-runners 4 --iterations 10 [--address HEAD_IP:6379]

Each RLlib EnvRunner (a Ray actor, on whichever node Ray places it) makes its environment with
`make_env` below: `gym.make("pcbdata/Route-d2-v2", ...)`, D2 boards generated on the fly (no
built set needed), so each EnvRunner owns one KiCad worker process, started at its first
reset. The learner trains on what the EnvRunners send back. See docs/ray.md ("RLlib").

RLlib's default models take a flat observation (Box) and a Discrete or MultiDiscrete action;
the environment's are nested dicts. This example flattens the observation with Gymnasium's
`FlattenObservation` (float32) and maps a MultiDiscrete action [type, net, candidate, mode]
onto the environment's Dict action. It ignores the action masks (`info["action_mask"]`): a
masked action is a no-op with the reason in `info["rejected"]`, so PPO learns to avoid them
slowly. `pcbdata.env.wrappers.rl` (a wrapper with fixed-size arrays, a MultiDiscrete action and the
masks in the observation, on its way on another branch) is the intended wrapper; use it in
place of `flat_env` once it lands.

Not run here: RLlib needs torch, which this machine (and CI) does not install. What was
checked: the API names against the RLlib source shipped in the installed Ray 2.60 wheel and
RLlib's documentation (new API stack, the default in Ray 2.60: `PPOConfig().environment(env,
env_config=...)`, `.env_runners(num_env_runners=..., num_envs_per_env_runner=...)`,
`.training(lr=..., train_batch_size_per_learner=..., minibatch_size=..., num_epochs=...)`,
`.debugging(seed=...)`, `.build_algo()`, `algo.train()`, the result keys
`env_runners/episode_return_mean`; an env registered with `ray.tune.registry.register_env`
is made on each EnvRunner by calling the creator with an `EnvContext`, a dict of
`env_config`); and `make_env` itself, run without RLlib: `python examples/rllib_ppo.py
--check-env` makes the wrapped environment and steps it with sampled actions.
"""
from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

ENV_ID = "pcbdata/Route-d2-v2"
#: Options of every EnvRunner's environment (see docs/env.md): short episodes, KiCad's DRC only
#: at the end of an episode (the cheaper setting for training), 1000 train boards.
ENV_CONFIG = {"split": "train", "count": 1000, "max_steps": 64, "drc": "terminal"}


class MultiDiscreteActions(gym.ActionWrapper):
    """The environment's Dict action {type, net, candidate, mode} as MultiDiscrete([7, nets,
    candidates, 3]). (`pcbdata.env.wrappers.rl` will do this, with masks.)"""

    KEYS = ("type", "net", "candidate", "mode")

    def __init__(self, env: gym.Env):
        super().__init__(env)
        spaces = env.action_space.spaces  # type: ignore[attr-defined]
        self.action_space = gym.spaces.MultiDiscrete([spaces[k].n for k in self.KEYS])

    def action(self, action):
        return {key: int(value) for key, value in zip(self.KEYS, action, strict=True)}


def flat_env(env: gym.Env) -> gym.Env:
    """A flat float32 Box observation and a MultiDiscrete action, for RLlib's default models."""
    env = gym.wrappers.FlattenObservation(env)
    env = gym.wrappers.DtypeObservation(env, np.float32)
    return MultiDiscreteActions(env)


def make_env(env_config) -> gym.Env:
    """RLlib's env creator: runs in each EnvRunner's process, so it imports `pcbdata.env` there
    (which registers the Gymnasium ids in that process) and makes the environment by its id.
    `env_config` is RLlib's EnvContext: a dict of `ENV_CONFIG` (plus worker_index and
    num_workers as attributes)."""
    import pcbdata.env  # noqa: F401 - registers pcbdata/Route-*-v2 in this process

    return flat_env(gym.make(ENV_ID, **dict(env_config)))


def check_env(steps: int = 20) -> None:
    """Without RLlib: the wrapped environment resets and steps with sampled actions."""
    env = make_env(ENV_CONFIG)
    try:
        obs, info = env.reset(seed=0)
        assert env.observation_space.contains(obs), "observation outside its space"
        total = 0.0
        for _ in range(steps):
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            total += float(reward)
            if terminated or truncated:
                obs, info = env.reset()
        print(f"ok: observation {env.observation_space.shape} {env.observation_space.dtype}, "
              f"action {env.action_space}, {steps} steps, reward {total:.3f}")
    finally:
        env.close()


def train(address: str | None, env_runners: int, iterations: int) -> None:
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.tune.registry import register_env

    ray.init(address=address)
    # Registered with RLlib under the environment's own Gymnasium id: RLlib ships the creator
    # to every EnvRunner (Gymnasium's registry is per process and does not travel).
    register_env(ENV_ID, make_env)
    config = (
        PPOConfig()
        .environment(ENV_ID, env_config=ENV_CONFIG)
        .env_runners(num_env_runners=env_runners, num_envs_per_env_runner=1)
        .training(lr=3e-4, train_batch_size_per_learner=1024, minibatch_size=128, num_epochs=4)
        .debugging(seed=0)
    )
    algo = config.build_algo()
    try:
        for iteration in range(iterations):
            result = algo.train()
            runners = result.get("env_runners", {})
            print(f"iteration {iteration}: episode return mean "
                  f"{runners.get('episode_return_mean')}, episode length mean "
                  f"{runners.get('episode_len_mean')}", flush=True)
    finally:
        algo.stop()
        ray.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--address", help="Ray cluster (default: RAY_ADDRESS, else local)")
    parser.add_argument("--env-runners", type=int, default=2, help="RLlib EnvRunners (actors)")
    parser.add_argument("--iterations", type=int, default=5, help="training iterations")
    parser.add_argument("--check-env", action="store_true",
                        help="only make the wrapped environment and step it (no RLlib needed)")
    args = parser.parse_args()
    if args.check_env:
        check_env()
    else:
        train(args.address, args.env_runners, args.iterations)


if __name__ == "__main__":
    main()

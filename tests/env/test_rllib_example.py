"""`examples/rllib_ppo.py`: its env creator makes the RL wrapper by its Gymnasium id with a flat
float32 observation and the wrapper's MultiDiscrete action; `--check-env` steps it; its PPO
config validates against the installed RLlib (skipped without RLlib). The training itself is
`bench/bench_rllib.py` (figures in docs/ray.md), too slow for the suite."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from pcbdata.env.wrappers.rl import observation_space

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rllib_ppo.py"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("rllib_ppo_example", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_env_creator_flattens_the_rl_wrapper(example):
    """The same seeded reset through the RL wrapper's id, flattened by hand, is the creator's
    observation, value for value."""
    import pcbdata.env  # noqa: F401 - registers the ids

    env = example.make_env(example.ENV_CONFIG)
    plain = gym.make(example.ENV_ID, **example.ENV_CONFIG)
    try:
        assert example.ENV_ID == "pcbdata/RouteRL-d2-v2"
        assert env.unwrapped.options.drc == "terminal"
        assert env.unwrapped.options.max_steps == example.ENV_CONFIG["max_steps"]
        wrapped = observation_space(env.unwrapped.options)
        assert plain.observation_space == wrapped
        assert env.observation_space.shape == (gym.spaces.flatdim(wrapped),)
        assert env.observation_space.dtype == np.float32
        assert env.action_space == plain.action_space == gym.spaces.MultiDiscrete([7, 64, 3])
        obs, _ = env.reset(seed=3)
        expected, _ = plain.reset(seed=3)
        assert obs.dtype == np.float32 and env.observation_space.contains(obs)
        np.testing.assert_array_equal(obs, gym.spaces.flatten(wrapped, expected).astype(np.float32))
        assert env.get_wrapper_attr("action_masks")().shape == (7 + 64 + 3,)
    finally:
        env.close()
        plain.close()


def test_check_env_steps_the_wrapped_environment(example, capsys):
    figures = example.check_env(steps=12)
    assert figures["dtype"] == "float32" and figures["steps"] == 12
    assert figures["action"] == "MultiDiscrete([ 7 64  3])"
    assert 0 <= figures["rejected"] <= 12
    assert capsys.readouterr().out.startswith("ok: ")


def test_ppo_config_validates(example):
    pytest.importorskip("ray.rllib", reason="RLlib (ray[rllib] + torch) is not installed")
    config = example.ppo_config(env_runners=1, train_batch=256)
    config.validate()
    assert (config.env, config.env_config) == (example.ENV_ID, example.ENV_CONFIG)
    assert (config.num_env_runners, config.train_batch_size_per_learner) == (1, 256)
    from ray.tune.registry import ENV_CREATOR, _global_registry

    assert _global_registry.contains(ENV_CREATOR, example.ENV_ID)

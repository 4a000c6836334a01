"""The registry: one id per config, gymnasium's own checks on every id, bad ids and options."""
from __future__ import annotations

import warnings

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env

import pcbdata.env  # noqa: F401
from pcbdata.env.registry import env_id
from pcbdata.sets.configs import registry
from tests.helpers import skip_without_snapshot

IDS = [env_id(name) for name in registry()]


def test_one_id_per_config():
    assert set(IDS) <= set(gym.registry)
    assert env_id("d2") == "pcbdata/Route-d2-v2"
    assert {"pcbdata/Route-d2-hard-v2", "pcbdata/Route-d1-g10-v2",
            "pcbdata/Route-d3-a-v2"} <= set(IDS)


@pytest.mark.parametrize("ident", IDS)
def test_check_env_passes(ident, request):
    """gymnasium's check_env (spaces, reset/step contracts, seeded determinism of reset and
    step) on every registered id. D1/D2/D2R: boards from the generator (no set needed; D2R
    with KiCad's DRC at the end);
    D3: the `d3_set` fixture (PCBDATA_D3_SET, else the real subset built from the PCBench
    snapshot), with KiCad's DRC at the end (a real board's DRC after every step is the slow
    part, and the contracts do not depend on when it runs), then 100 random steps on the
    tier's smallest test board."""
    options: dict = {}
    if "-d2r-" in ident:
        options = {"drc": "terminal"}  # realistic boards: hundreds of pads, DRC at the end
    if "-d3-" in ident:
        options = {"root": str(_d3_root(ident, request.getfixturevalue("d3_set"))),
                   "drc": "terminal"}
    env = gym.make(ident, **options)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # check_env's warnings are failures here
            check_env(env.unwrapped)
        if "-d3-" in ident:
            _random_steps(env, 100, _smallest_board(env))
    finally:
        env.close()


def _d3_root(ident: str, d3_set):
    tier = ident.split("Route-", 1)[1].rsplit("-v", 1)[0]
    if not any((d3_set / tier / "test").glob("*/board.kicad_pcb")):
        skip_without_snapshot(f"the D3 set {d3_set} has no {tier} test boards")
    return d3_set


def _smallest_board(env) -> str:
    source = env.unwrapped.source
    sizes = {board_id: (source.folder(i, None) / "board.kicad_pcb").stat().st_size
             for i, board_id in enumerate(source.board_ids)}
    return min(sorted(sizes), key=sizes.__getitem__)


def _random_steps(env, steps: int, board_id: str) -> None:
    """Seeded masked-random actions on a real board never crash (D3: real netclasses, zones,
    many layers)."""
    from pcbdata.agents.random import RandomAgent

    agent = RandomAgent(7)
    obs, info = env.reset(seed=7, options={"board_id": board_id})
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        assert "engine_failure" not in info
        if terminated or truncated:
            obs, info = env.reset(options={"board_id": board_id})


def test_wrong_id_suggests_the_closest():
    with pytest.raises(gym.error.Error, match="Route-d2"):
        gym.make("pcbdata/Route-d22-v2")


def test_unknown_option_suggests_the_closest():
    with pytest.raises(TypeError, match="did you mean 'max_steps'"):
        gym.make("pcbdata/Route-d2-v2", max_step=10)


def test_bad_choice_suggests_the_closest():
    with pytest.raises(ValueError, match="did you mean 'terminal'"):
        gym.make("pcbdata/Route-d2-v2", drc="terminl")


@pytest.mark.parametrize("option, value", [
    ("router_nodes", -1), ("router_checks", 2.5), ("router_checks", True),
    ("router_seconds", float("nan")), ("router_seconds", 0), ("router_seconds", "2"),
])
def test_a_bad_router_budget_is_refused_by_name(option, value):
    with pytest.raises(ValueError, match=option):
        gym.make("pcbdata/Route-d2-v2", **{option: value})


def test_the_router_budget_counts_work_by_default():
    from pcbdata.env.options import make_options

    options = make_options()
    assert options.router_seconds is None and options.router_checks > 0
    assert make_options(router_seconds=2.0).router_seconds == 2.0


@pytest.mark.parametrize("old, current", [
    ("pcbdata/Route-d2-v0", "pcbdata/Route-d2-v2"), ("pcbdata/Route-d2-v1", "pcbdata/Route-d2-v2"),
    ("pcbdata/Route-d3-a-v1", "pcbdata/Route-d3-a-v2"),
    ("pcbdata/RouteRL-d2-v1", "pcbdata/RouteRL-d2-v2"), ("pcbdata/Route-v1", "pcbdata/Route-v2"),
])
def test_an_older_version_names_the_current_one(old, current):
    from pcbdata.env.registry import VERSION

    assert VERSION == 2
    with pytest.raises(gym.error.DeprecatedEnv, match=current):
        gym.make(old)

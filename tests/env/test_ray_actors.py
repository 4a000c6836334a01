"""Environment workers as Ray actors (`pcbdata.runners.ray_actors`) on the 2-CPU local
Ray cluster: seeded episodes stepped on two actors give the observations, rewards and saved
boards of the same episodes run locally; a killed actor is one clear error; no actor and no
KiCad worker outlives its end."""
from __future__ import annotations

import re

import pytest

from pcbdata.agents.scripted import ScriptedAgent
from tests.env.agents_for_tests import StopsEarly
from tests.processes import running, wait_for

ENV_ID = "pcbdata/Route-d2-v2"
EPISODES = [("board_00000", 0), ("board_00001", 0), ("board_00002", 1), (None, 3)]


def _agent(seed: int):
    """Scripted; seed 1's stops after 6 steps, so its episode ends by `finish_episode`."""
    return StopsEarly(ScriptedAgent(seed=seed), 6) if seed == 1 else ScriptedAgent(seed=seed)


def _alive(pids: list[int]) -> list[int]:
    return running(pids)


def _processes(ray, actors) -> list[int]:
    found = ray.get([actor.processes.remote() for actor in actors])
    assert all(entry["children"] for entry in found)  # each has its KiCad worker
    return [pid for entry in found for pid in (entry["actor"], *entry["children"])]


@pytest.mark.slow
def test_episodes_on_two_actors_are_the_local_episodes(ray_cluster, board_set, make_env,
                                                        tmp_path):
    from pcbdata.runners.ray_actors import close_actors, make_actors, run_episodes, step_episodes

    options = {"root": str(board_set), "split": "test", "max_steps": 30}
    local = run_episodes(make_env("d2", max_steps=30), _agent, EPISODES,
                         save_dir=str(tmp_path / "local"))
    actors = make_actors(2, ENV_ID, **options)
    try:
        remote = step_episodes(actors, _agent, EPISODES, save_dir=str(tmp_path / "ray"))
        pids = _processes(ray_cluster, actors)
    finally:
        close_actors(actors)
    assert [e.board_id for e in remote][:3] == ["board_00000", "board_00001", "board_00002"]
    early = [e.seed == 1 for e in remote]
    assert all(e.steps > 3 and len(e.obs_digests) == e.steps + 1 + stop
               and len(e.rewards) == e.steps + stop for e, stop in zip(remote, early, strict=True))
    assert [(e.steps, e.truncated) for e in remote if e.seed == 1] == [(6, True)]
    for mine, theirs in zip(remote, local, strict=True):
        assert (mine.obs_digests, mine.rewards) == (theirs.obs_digests, theirs.rewards)
        assert mine.saved != theirs.saved and mine.saved is not None and theirs.saved
        with open(mine.saved, "rb") as a, open(theirs.saved, "rb") as b:
            assert a.read() == b.read()
    assert [vars(e) | {"saved": None} for e in remote] == \
        [vars(e) | {"saved": None} for e in local]
    assert wait_for(lambda: not _alive(pids), 20), _alive(pids)


@pytest.mark.slow
def test_a_killed_actor_is_one_clear_error_and_leaves_no_process(ray_cluster, board_set):
    from pcbdata.runners.ray_actors import EnvActorError, close_actors, make_actors, step_episodes

    actors = make_actors(2, ENV_ID, root=str(board_set), max_steps=30)
    ray_cluster.get([a.reset.remote(seed=0, options={"index": 0}) for a in actors])
    pids = _processes(ray_cluster, actors)

    class KillsActorZero(ScriptedAgent):
        def act(self, obs, info):
            if int(obs["step"]) == 2:
                ray_cluster.kill(actors[0])
            return super().act(obs, info)

    try:
        with pytest.raises(EnvActorError) as caught:
            step_episodes(actors, lambda seed: KillsActorZero(seed=seed), [("board_00000", 7)])
    finally:
        close_actors(actors)
    assert re.fullmatch(r"environment actor 0 died during step \(board board_00000, seed 7, "
                        r"after 2 steps\): \w+: .+", str(caught.value)), str(caught.value)
    assert caught.value.message() == str(caught.value)  # one line
    assert wait_for(lambda: not _alive(pids), 20), _alive(pids)


def test_a_bad_option_or_id_is_the_environment_s_error_on_the_driver(ray_cluster):
    import gymnasium as gym

    from pcbdata.env.errors import EnvOptionError
    from pcbdata.runners.ray_actors import make_actors

    with pytest.raises(EnvOptionError, match="did you mean 'max_steps'"):
        make_actors(1, ENV_ID, max_stepz=3)
    with pytest.raises(gym.error.Error):
        make_actors(1, "pcbdata/Route-d2x-v2")

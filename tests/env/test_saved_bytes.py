"""A saved rollout board is the same bytes whatever the worker ran before: KiCad mints random
UUIDs (for the footprint properties it adds at load, for new tracks and vias), which
`routing_session` seeds per episode, so `pcbdata rollout` gives the same files on any worker
and any executor (tests/env/test_rollout_ray.py compares local and Ray)."""
from __future__ import annotations

from pcbdata.agents.registry import make_agent
from pcbdata.runners.rollout import run_episode


def _episode(env, board_id: str, path) -> bytes:
    run_episode(env, make_agent("scripted", 0), board_id, 0)
    env.unwrapped.save(str(path))
    return path.read_bytes()


def test_the_same_episode_saves_the_same_bytes_in_any_worker(make_env, tmp_path):
    env = make_env("d2", max_steps=30)
    first = _episode(env, "board_00000", tmp_path / "a.kicad_pcb")  # the worker's first board
    _episode(env, "board_00001", tmp_path / "b.kicad_pcb")
    again = _episode(env, "board_00000", tmp_path / "c.kicad_pcb")  # after other episodes
    fresh = _episode(make_env("d2", max_steps=30), "board_00000", tmp_path / "d.kicad_pcb")
    assert b"(segment" in first
    assert first == again == fresh


def test_a_worker_that_holds_too_much_memory_is_replaced_without_changing_episodes(
        make_env, tmp_path, monkeypatch):
    from pcbdata.env.session import KicadSession

    env = make_env("d2", max_steps=30)
    first = _episode(env, "board_00000", tmp_path / "a.kicad_pcb")
    worker = env.unwrapped._session._pool.call("os:getpid")
    monkeypatch.setattr(KicadSession, "RECYCLE_MIB", 1)  # every worker holds more than 1 MiB
    again = _episode(env, "board_00000", tmp_path / "b.kicad_pcb")
    assert env.unwrapped._session._pool.call("os:getpid") != worker
    assert first == again

"""The environment on hard and failing steps: a step KiCad refuses keeps the board built so far,
and the default step limit follows the board."""
from __future__ import annotations

import pytest

from pcbdata.env import operations
from pcbdata.env.env import step_limit
from pcbdata.env.types import MAKE_LINE, MAKE_VIA, MARK_OBSTACLES, NET_END, NET_SELECT, START_ROUTE


def _copper(env) -> list[tuple]:
    """The board's copper as KiCad reports it, without cluster labels."""
    return sorted((r["kind"], r["net"], r.get("layer"), tuple(r.get("start", ())),
                   tuple(r.get("end", ())), r.get("x"), r.get("y"))
                  for r in env.unwrapped._snap["copper"])


def _route_until_copper(env, obs, info):
    """The scripted agent's steps until the board has copper and a head is down."""
    from pcbdata.agents.scripted import ScriptedAgent

    agent, total = ScriptedAgent(seed=0), 0.0
    while not (env.unwrapped._snap["copper"] and info["phase"] == "routing"):
        obs, reward, terminated, truncated, info = env.step(agent.act(obs, info))
        total += reward
        assert not (terminated or truncated)
    return obs, info, total


def test_a_refused_edit_keeps_the_last_good_board(make_env, monkeypatch, tmp_path):
    env = make_env("d2", drc="terminal")
    obs, info = env.reset(options={"board_id": "board_00000"})
    phi0 = info["phi"]
    obs, info, total = _route_until_copper(env, obs, info)
    good = _copper(env)
    assert good, "the finished connection left no copper"
    bad_net = info["net"]

    def refused(static, router, net, head, goal, mode, times, extra=()):
        # A real track, then a removal of a track that is not there: KiCad adds the first and
        # refuses the second, so its board is half-edited when the step fails.
        track = {"kind": "track", "net": net.name, "layer": static.layers[head.layer],
                 "points": [(head.x, head.y), tuple(goal)], "width": net.track_width}
        missing = {"kind": "remove", "net": bad_net, "layer": static.layers[0],
                   "start": (1, 1), "end": (2, 2), "width": net.track_width}
        return operations.Outcome(True, edits=[track, missing], head=head)

    monkeypatch.setattr(operations, "make_line", refused)
    line = int(next(i for i, m in enumerate(info["action_mask"]["candidate"]) if m))
    obs, reward, terminated, truncated, info = env.step(
        {"type": MAKE_LINE, "net": 0, "candidate": line, "mode": 0})
    assert truncated and not terminated
    assert "no track of net" in info["engine_failure"]
    assert _copper(env) == good  # the half-edit is gone, the connection made before is kept
    total += reward
    assert total == pytest.approx(info["phi"] - phi0)
    saved = env.unwrapped.save(tmp_path / "kept.kicad_pcb")
    text = open(saved, encoding="utf-8").read()
    assert text.count("(segment") == sum(1 for c in good if c[0] != "via")
    _, _, _, _, after = env.step({"type": 0, "net": 0, "candidate": 0, "mode": 0})
    assert after["rejected"].startswith("the episode has ended")


def test_default_step_limit_scales_with_the_board(make_env):
    env = make_env("d2")
    _, info = env.reset(options={"board_id": "board_00000"})
    assert info["max_steps"] == step_limit(info["unconnected"]) == env.unwrapped.max_steps
    assert step_limit(3) == 200 and step_limit(100) == 800
    fixed = make_env("d2", max_steps=7)
    _, info = fixed.reset(options={"board_id": "board_00000"})
    assert info["max_steps"] == 7


def _first(mask) -> int:
    return int(next(i for i, m in enumerate(mask) if m))


@pytest.mark.parametrize("cleanup", [True, False])
def test_net_end_takes_up_a_route_that_went_nowhere(make_env, cleanup):
    """A line to a ring point and a via there: both dangle; `net_end` deletes them (KiCad's
    DRC then has no dangling item), unless cleanup=False."""
    env = make_env("d2", cleanup=cleanup)
    obs, info = env.reset(options={"board_id": "board_00000"})
    net = _first(info["action_mask"]["net"])
    env.step({"type": NET_SELECT, "net": net, "candidate": 0, "mode": 0})
    env.step({"type": START_ROUTE, "net": 0, "candidate": _first(_masks(env)["candidate"]),
              "mode": 0})
    ring = _first(_masks(env)["candidate"][:8])
    obs, _, _, _, info = env.step({"type": MAKE_VIA, "net": 0, "candidate": ring,
                                   "mode": MARK_OBSTACLES})
    assert info["router"]["ok"] and info["vias"] == 1
    dangling = {"track_dangling", "via_dangling"} & set(_types(env))
    assert "via_dangling" in dangling
    obs, _, _, _, info = env.step({"type": NET_END, "net": 0, "candidate": 0, "mode": 0})
    left = {"track_dangling", "via_dangling"} & set(_types(env))
    assert (left, info["vias"], info["wl_mm"]) == ((set(), 0, 0.0) if cleanup else
                                                   (dangling, 1, info["wl_mm"]))


def _masks(env):
    return env.unwrapped.action_masks()


def _types(env) -> list[str]:
    return [v["type"] for v in env.unwrapped._violations]


def test_a_worker_killed_mid_episode_keeps_the_board(make_env, tmp_path):
    """KiCad's worker dies: the next copper step reloads the board in a fresh worker with the
    edits made so far, and the episode ends on that board, saved."""
    import os
    import signal

    env = make_env("d2", drc="terminal")
    obs, info = env.reset(options={"board_id": "board_00001"})
    obs, info, _ = _route_until_copper(env, obs, info)
    good = _copper(env)
    os.kill(env.unwrapped._session._pool.call("os:getpid"), signal.SIGKILL)
    line = _first(_masks(env)["candidate"])
    _, _, terminated, truncated, info = env.step(
        {"type": MAKE_LINE, "net": 0, "candidate": line, "mode": MARK_OBSTACLES})
    assert truncated and not terminated and info["engine_failure"]
    assert _copper(env) == good
    saved = env.unwrapped.save(tmp_path / "kept.kicad_pcb")
    assert open(saved, encoding="utf-8").read().count("(segment") == \
        sum(1 for c in good if c[0] != "via")

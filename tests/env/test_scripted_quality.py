"""Walkaround routes are legal by construction: the scripted agent's boards (walkaround mode
only) carry no clearance, shorting or crossing violation (D2 test sample)."""
from __future__ import annotations

from pcbdata.agents.rollout import run_episode
from pcbdata.agents.scripted import ScriptedAgent

GEOMETRY_VIOLATIONS = {"clearance", "shorting_items", "tracks_crossing", "copper_edge_clearance",
                       "hole_clearance", "hole_to_hole"}


def test_scripted_walkaround_boards_have_no_geometry_violation(make_env):
    env = make_env(drc="terminal")
    connected = 0
    for index in range(4):
        record = run_episode(env, ScriptedAgent(seed=0), f"board_{index:05d}", 0)
        env.unwrapped._final_drc()
        kinds = {v["type"] for v in env.unwrapped._violations}
        assert not kinds & GEOMETRY_VIOLATIONS, (index, sorted(kinds))
        connected += env.unwrapped._state["unconnected"] == 0
        assert record["steps"] > 0
    assert connected >= 3

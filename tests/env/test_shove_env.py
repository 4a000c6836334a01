"""push_n_shove in the environment: edits undone, and shoving episodes on real D2 boards in
KiCad (connectivity kept, no new clearance violation, undo, determinism). The plan alone, on
plain geometry, is tested in `tests/router/test_shove.py`."""
from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from pcbdata.env import operations
from pcbdata.env.types import FINISH, PUSH_N_SHOVE
from pcbdata.testing.sets import write_set
from tests.router.test_shove import B_DIP
from tests.router.test_walkaround import WIDTH


def test_undo_reverses_edits():
    edits = [operations.remove_edit(B_DIP[0]),
             {"kind": "track", "net": "A", "layer": "F.Cu", "points": [(0, 0), (5, 0), (5, 5)],
              "width": WIDTH},
             {"kind": "via", "net": "A", "at": (5, 5), "diameter": 600, "drill": 300}]
    back = operations.undo(edits)
    assert [e["kind"] for e in back] == ["remove_via", "remove", "remove", "track"]
    assert back[1]["start"] == (5, 0) and back[2]["start"] == (0, 0)
    assert back[3]["points"] == [B_DIP[0].start, B_DIP[0].end]


# --- in KiCad -----------------------------------------------------------------------------

SHOVE_BOARD = "board_00003"  # a d2-expert board where shoves succeed and fail
ERRORS = {"clearance", "shorting_items", "tracks_crossing", "copper_edge_clearance",
          "hole_clearance", "hole_to_hole"}


def _new_errors(before: list[dict], after: list[dict]) -> Counter:
    """Violations of an error type a step added, counted per type: a second clearance
    violation is new even where the board already had one."""
    added = Counter(v["type"] for v in after) - Counter(v["type"] for v in before)
    return Counter({kind: n for kind, n in added.items() if kind in ERRORS})


def test_a_second_violation_of_a_type_the_board_had_is_new():
    one, other = {"type": "clearance"}, {"type": "unconnected_items"}
    assert _new_errors([one], [one, one]) == Counter({"clearance": 1})
    assert not _new_errors([one, other], [one, other, other])


@pytest.fixture(scope="module")
def expert_set(tmp_path_factory):
    return write_set(tmp_path_factory.mktemp("expert"), "d2-expert", "test", 4)


def _make(root):
    import gymnasium as gym

    import pcbdata.env  # noqa: F401
    return gym.make("pcbdata/Route-d2-expert-v2", root=str(root), split="test")


def _episode(env, board_id: str):
    """The scripted agent with the push_n_shove fallback; returns (actions, rewards, shoves):
    per push_n_shove step (step index, router info, violations before and after, clusters
    before and after, track rows before and after)."""
    from pcbdata.agents.scripted import ShovingScriptedAgent

    agent, u = ShovingScriptedAgent(seed=0), env.unwrapped
    obs, info = env.reset(options={"board_id": board_id})
    actions, rewards, shoves = [], [], []
    while True:
        a = agent.act(obs, info)
        if agent.done:
            break
        before, clusters = list(u._violations), dict(u._snap["clusters"])
        tracks = obs["routing_geometry"]["tracks"].copy()
        obs, reward, terminated, truncated, info = env.step(a)
        actions.append(a)
        rewards.append(reward)
        if a["mode"] == PUSH_N_SHOVE and a["type"] == FINISH:
            shoves.append((len(actions) - 1, info["router"], before, list(u._violations),
                           clusters, dict(u._snap["clusters"]), tracks,
                           obs["routing_geometry"]["tracks"]))
        if terminated or truncated:
            break
    return actions, rewards, shoves


@pytest.fixture(scope="module")
def shoving_episode(expert_set):
    env = _make(expert_set)
    try:
        yield _episode(env, SHOVE_BOARD)
    finally:
        env.close()


def test_shoves_on_a_real_board_keep_connections_and_clearance(shoving_episode):
    moved = failed = 0
    for _, router, before, after, clusters, clusters_after, tracks, tracks_after in \
            shoving_episode[2]:
        if not router["ok"]:
            failed += 1
            np.testing.assert_array_equal(tracks, tracks_after)  # nothing changed
            continue
        if router["stats"].get("method") != "shove":
            continue
        moved += 1
        assert not _new_errors(before, after), _new_errors(before, after)
        assert all(clusters_after[n] <= clusters[n] for n in clusters)
    assert moved >= 1 and failed >= 1


def test_shoving_episodes_are_deterministic(make_env, expert_set, shoving_episode):
    actions, rewards, _ = shoving_episode
    env = make_env("d2-expert", root=str(expert_set))
    env.reset(options={"board_id": SHOVE_BOARD})
    assert [env.step(a)[1] for a in actions] == rewards


def test_a_lost_connection_is_undone(make_env, expert_set, shoving_episode, monkeypatch):
    actions, _, shoves = shoving_episode
    first = next(step for step, router, *_ in shoves
                 if router["ok"] and router["stats"].get("method") == "shove")
    env = make_env("d2-expert", root=str(expert_set))
    obs, _ = env.reset(options={"board_id": SHOVE_BOARD})
    for a in actions[:first]:
        obs, *_ = env.step(a)
    monkeypatch.setattr(operations, "lost_connections", lambda before, after, nets: list(nets))
    obs2, _, _, _, info = env.step(actions[first])
    assert not info["router"]["ok"] and "undone" in info["router"]["reason"]
    np.testing.assert_array_equal(obs2["routing_geometry"]["tracks"],
                                  obs["routing_geometry"]["tracks"])
    np.testing.assert_array_equal(obs2["routing_geometry"]["vias"], obs["routing_geometry"]["vias"])


def test_a_rejoin_under_the_new_path_keeps_connections_and_clearance_in_kicad(shoving_episode):
    """On this board a moved net is joined again on the other layer, a via near each end."""
    under = [s for s in shoving_episode[2] if s[1]["ok"] and s[1]["stats"].get("rejoins_under")]
    assert under, "the board no longer needs a re-join under the new path"
    _assert_no_new_error_and_no_lost_connection(under)


HOP_BOARD = "board_00005"  # a d2-expert board where a moved net is joined again by a via


@pytest.fixture(scope="module")
def hop_episode(tmp_path_factory):
    env = _make(write_set(tmp_path_factory.mktemp("hop"), "d2-expert", "test", 6))
    try:
        yield _episode(env, HOP_BOARD)
    finally:
        env.close()


def test_a_rejoin_through_a_via_keeps_connections_and_clearance_in_kicad(hop_episode):
    hops = [s for s in hop_episode[2] if s[1]["ok"] and s[1]["stats"].get("rejoin_vias")]
    assert hops, "the board no longer needs a via re-join"
    _assert_no_new_error_and_no_lost_connection(hops)


def _assert_no_new_error_and_no_lost_connection(steps) -> None:
    for _, _, before, after, clusters, clusters_after, _, _ in steps:
        assert not _new_errors(before, after), _new_errors(before, after)
        assert all(clusters_after[n] <= clusters[n] for n in clusters)

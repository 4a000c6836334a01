"""push_n_shove (`pcbdata.env.shove` and the environment's use of it): the plan alone on plain
geometry, checked against the independent exact model of `test_walkaround.py`, then on real
D2 boards in KiCad (connectivity kept, no new clearance violation, undo, determinism)."""
from __future__ import annotations

import random

import numpy as np
import pytest

from pcbdata.env import routing
from pcbdata.env.geometry import BoardGeometry
from pcbdata.env.shove import path_items, plan
from pcbdata.env.types import FINISH, PUSH_N_SHOVE
from pcbdata.env.walkaround import WalkaroundRouter
from tests.env.conftest import write_set
from tests.env.test_walkaround import CLEARANCE, MM, WIDTH, board, exact_gaps, pad, request, wall

# A narrow board: net A must run straight along y = 9 mm between its pads; net B's pads sit on
# the top edge and its track dips down across A's way, so walkaround alone cannot pass.
OUTLINE = ((0, 1_400_000), (20 * MM, 1_400_000), (20 * MM, 10 * MM), (0, 10 * MM))
B_DIP = (wall("B", 8, 2.5, 8, 9, 0.25), wall("B", 8, 9, 12, 9, 0.25),
         wall("B", 12, 9, 12, 2.5, 0.25))


def _board(*extra) -> BoardGeometry:
    return board(pad("A", 2, 9), pad("A", 18, 9), pad("B", 8, 2.5), pad("B", 12, 2.5),
                 *B_DIP, *extra, outline=(OUTLINE,))


def _after(geometry: BoardGeometry, done, req) -> BoardGeometry:
    """The board once the plan is applied."""
    gone = set(done.removed)
    items = [i for i in geometry.copper if i not in gone]
    items += path_items(req.net, req.layer, done.path, req.width, req.clearance)
    for r in done.reroutes:
        items += path_items(r.net, req.layer, r.path, r.width, CLEARANCE)
    return BoardGeometry(geometry.outline, tuple(items), geometry.edge_clearance)


def test_walkaround_alone_cannot_pass():
    assert WalkaroundRouter(_board()).route(request("A", (2, 9), (18, 9))).path is None


def test_blocking_tracks_are_taken_up_and_their_net_joined_again_legally():
    geometry, req = _board(), request("A", (2, 9), (18, 9))
    done = plan(WalkaroundRouter(geometry), req)
    assert done.path == ((2 * MM, 9 * MM), (18 * MM, 9 * MM)), done.reason
    assert set(done.removed) == set(B_DIP) and done.moved_nets == ("B",)
    assert [(r.net, r.path[0], r.path[-1]) for r in done.reroutes] == \
        [("B", (8 * MM, 2_500_000), (12 * MM, 2_500_000))]
    final = _after(geometry, done, req)
    assert min(exact_gaps(final, req, done.path)) >= 0
    for r in done.reroutes:
        own = request("B", (8, 2.5), (12, 2.5), width=r.width)
        assert min(exact_gaps(final, own, r.path)) >= 0
    assert done.stats["method"] == "shove" and done.stats["moved_tracks"] == 3


def test_the_plan_does_not_depend_on_item_order():
    geometry, req = _board(), request("A", (2, 9), (18, 9))
    items = list(geometry.copper)
    random.Random(1).shuffle(items)
    shuffled = BoardGeometry(geometry.outline, tuple(items), geometry.edge_clearance)
    assert plan(WalkaroundRouter(shuffled), req) == plan(WalkaroundRouter(geometry), req)


def test_no_shove_when_walkaround_finds_a_path():
    geometry = board(pad("A", 2, 9), pad("A", 18, 9), wall("B", 8, 2, 8, 5))
    done = plan(WalkaroundRouter(geometry), request("A", (2, 9), (18, 9)))
    assert done.path is not None and done.removed == () and done.reroutes == ()
    assert done.stats["shove"] == "not_needed"


def test_pads_are_not_moved():
    geometry = board(pad("A", 2, 9), pad("A", 18, 9), pad("C", 10, 6, size=7.9),
                     outline=(OUTLINE,))
    done = plan(WalkaroundRouter(geometry), request("A", (2, 9), (18, 9)))
    assert done.path is None and "no other net's track to move" in done.reason


def test_a_net_that_cannot_be_joined_again_changes_nothing():
    # B's pads below A's way: once A runs along y = 9, B's two sides are cut apart.
    # A's pads reach the side edges, so nothing passes around A's ends either.
    geometry = board(pad("A", 1, 9), pad("A", 19, 9), pad("B", 10, 9.9, size=0.2),
                     pad("B", 10, 3, size=0.6), wall("B", 10, 3, 10, 9.9, 0.25),
                     outline=(((0, 2 * MM), (20 * MM, 2 * MM), (20 * MM, 10.6 * MM),
                               (0, 10.6 * MM)),))
    done = plan(WalkaroundRouter(geometry), request("A", (1, 9), (19, 9)))
    assert done.path is None and "'B'" in done.reason
    assert done.removed == () and done.reroutes == ()


def test_undo_reverses_edits():
    edits = [routing.remove_edit(B_DIP[0]),
             {"kind": "track", "net": "A", "layer": "F.Cu", "points": [(0, 0), (5, 0), (5, 5)],
              "width": WIDTH},
             {"kind": "via", "net": "A", "at": (5, 5), "diameter": 600, "drill": 300}]
    back = routing.undo(edits)
    assert [e["kind"] for e in back] == ["remove_via", "remove", "remove", "track"]
    assert back[1]["start"] == (5, 0) and back[2]["start"] == (0, 0)
    assert back[3]["points"] == [B_DIP[0].start, B_DIP[0].end]


# --- in KiCad -----------------------------------------------------------------------------

SHOVE_BOARD = "board_00001"  # a d2-expert board where shoves succeed and fail
ERRORS = {"clearance", "shorting_items", "tracks_crossing", "copper_edge_clearance",
          "hole_clearance"}


@pytest.fixture(scope="module")
def expert_set(tmp_path_factory):
    return write_set(tmp_path_factory.mktemp("expert"), "d2-expert", "test", 2)


def _make(root):
    import gymnasium as gym

    import pcbdata.env  # noqa: F401
    return gym.make("pcbdata/Route-d2-expert-v1", root=str(root), split="test")


def _episode(env, board_id: str):
    """The scripted agent with the push_n_shove fallback; returns (actions, rewards, shoves):
    per push_n_shove step (step index, router info, violations before and after, clusters
    before and after, track rows before and after)."""
    from pcbdata.env.agents import ShovingScriptedAgent

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
        new = {v["type"] for v in after} - {v["type"] for v in before}
        assert not new & ERRORS, new
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
    monkeypatch.setattr(routing, "lost_connections", lambda before, after, nets: list(nets))
    obs2, _, _, _, info = env.step(actions[first])
    assert not info["router"]["ok"] and "undone" in info["router"]["reason"]
    np.testing.assert_array_equal(obs2["routing_geometry"]["tracks"],
                                  obs["routing_geometry"]["tracks"])
    np.testing.assert_array_equal(obs2["routing_geometry"]["vias"], obs["routing_geometry"]["vias"])

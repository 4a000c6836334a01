"""Walkaround routes are legal by construction, judged by KiCad's DRC: boards routed by the
scripted agent (walkaround mode only) and by `D1Agent` carry no clearance, edge-clearance,
shorting or crossing violation. D1 routes at exactly the clearance (a track leaving a pad sits
at the edge clearance from the edge and at the clearance from the next cell's pad), so these
boards check the router's exact rule, not a padded one: all five grids, D2 and D3-A."""
from __future__ import annotations

from pathlib import Path

import pytest

from pcbdata.agents.d1 import D1Agent
from pcbdata.agents.scripted import ScriptedAgent
from pcbdata.runners.rollout import run_episode
from tests.helpers import skip_without_snapshot

GEOMETRY_VIOLATIONS = {"clearance", "shorting_items", "tracks_crossing", "copper_edge_clearance",
                       "hole_clearance", "hole_to_hole"}
D1_GRIDS = (10, 50, 100, 200, 500)
D1_BOARDS = 3


@pytest.fixture(scope="module")
def d1_set(tmp_path_factory) -> Path:
    from pcbdata.testing.sets import write_set

    root = tmp_path_factory.mktemp("d1-quality")
    for grid in D1_GRIDS:
        write_set(root, f"d1-g{grid}", "test", D1_BOARDS)
    return root


def _route(env, agent, board_id: str) -> tuple[set[str], int, dict]:
    """The episode's violation types after a final DRC, U, and the rollout record."""
    record = run_episode(env, agent, board_id, agent.seed)
    env.unwrapped._final_drc()
    kinds = {v["type"] for v in env.unwrapped._violations}
    return kinds, env.unwrapped._state["unconnected"], record


def test_scripted_walkaround_boards_have_no_geometry_violation(make_env):
    env = make_env(drc="terminal")
    connected = 0
    for index in range(4):
        kinds, unconnected, record = _route(env, ScriptedAgent(seed=0), f"board_{index:05d}")
        assert not kinds & GEOMETRY_VIOLATIONS, (index, sorted(kinds))
        connected += unconnected == 0
        assert record["steps"] > 0
    assert connected >= 3


@pytest.mark.parametrize("grid", D1_GRIDS)
def test_d1_boards_at_exact_clearance_pass_kicad_drc(make_env, d1_set, grid):
    """Both agents on every grid: no geometry violation, and the copper really sits at the
    clearance (before the exact rule, no net of D1-10 board 0 could even start)."""
    env = make_env(f"d1-g{grid}", root=str(d1_set), drc="terminal")
    connected = 0
    for index in range(D1_BOARDS):
        for agent in (ScriptedAgent(seed=0), D1Agent(seed=0)):
            kinds, unconnected, record = _route(env, agent, f"board_{index:05d}")
            assert not kinds & GEOMETRY_VIOLATIONS, (grid, index, type(agent), sorted(kinds))
            connected += unconnected == 0
    # Episodes that end with every net joined, of 6: D1-10 is hard (uniform placement), the
    # larger grids nearly free.
    assert connected >= (1 if grid == 10 else D1_BOARDS + 2), connected


def test_d1_agent_lays_tracks_at_exactly_the_clearance(make_env, d1_set):
    """D1-10 board 0: the lattice plan puts tracks of different nets one pitch apart, i.e. at
    exactly the clearance, and KiCad's DRC accepts it."""
    env = make_env("d1-g10", root=str(d1_set), drc="terminal")
    agent = D1Agent(seed=0)
    kinds, unconnected, _ = _route(env, agent, "board_00000")
    assert unconnected == 0 and not kinds & GEOMETRY_VIOLATIONS, sorted(kinds)
    tracks = env.unwrapped._snap["copper"]
    pitch = round(agent._grid.pitch * 1e6)
    assert _closest_other_net_gap(tracks) == pitch // 2  # copper edge to copper edge


def _closest_other_net_gap(copper: list[dict]) -> float:
    import shapely

    tracks = [c for c in copper if c["kind"] == "track"]
    best = float("inf")
    for i, a in enumerate(tracks):
        for b in tracks[i + 1:]:
            if a["net"] != b["net"]:
                gap = shapely.distance(shapely.LineString([a["start"], a["end"]]),
                                       shapely.LineString([b["start"], b["end"]]))
                best = min(best, gap - a["width"] / 2 - b["width"] / 2)
    return best


def test_d3_a_scripted_boards_have_no_geometry_violation(d3_set):
    import gymnasium as gym

    import pcbdata.env  # noqa: F401

    if not any((d3_set / "d3-a" / "test").glob("*/board.kicad_pcb")):
        skip_without_snapshot("needs a built D3 set with d3-a test boards: PCBDATA_D3_SET=<set>")
    env = gym.make("pcbdata/Route-d3-a-v2", root=str(d3_set), drc="terminal", max_steps=80)
    made, completed = 0, 0
    try:
        for board_id in env.unwrapped.source.board_ids[:3]:
            _, info = env.reset(seed=0, options={"board_id": board_id})
            kinds, unconnected, _ = _route(env, ScriptedAgent(seed=0), board_id)
            assert not kinds & GEOMETRY_VIOLATIONS, (board_id, sorted(kinds))
            made += info["unconnected"] - unconnected  # connections the copper made
            completed += unconnected == 0
    finally:
        env.close()
    # The three smallest D3-A boards open 3 + 3 + 4 connections; today every one is made.
    assert completed == 3 and made >= 10, (completed, made)


def _grid(size: int, pads: dict):
    from pcbdata.agents.d1 import D1Grid

    return D1Grid.of(1.0, size, pads)


def _assert_valid_plan(grid, paths: dict) -> None:
    seen: dict = {}
    for net, path in paths.items():
        assert [path[0], path[-1]] == grid.pads[net]
        assert all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 for a, b in zip(path, path[1:]))
        for cell in path:
            assert seen.setdefault(cell, net) == net, (cell, net)  # one net per cell


def test_d1_plan_rips_up_a_net_that_walls_another_in():
    """Net 0 first takes the short way under net 1's pad, which seals net 1 in; the planner
    rips net 0 up, routes net 1 and sends net 0 around the board."""
    from pcbdata.agents.d1 import plan_d1

    grid = _grid(4, {0: [(0, 0), (2, 0)], 1: [(1, 0), (1, 2)]})
    paths = plan_d1(grid, [0, 1])
    assert sorted(paths) == [0, 1]
    _assert_valid_plan(grid, paths)
    assert len(paths[0]) > 5  # the long way round
    assert grid.walled_nets() == []


def test_d1_walled_in_pads_are_the_ceiling():
    from pcbdata.agents.d1 import plan_d1

    grid = _grid(4, {0: [(0, 0), (3, 3)], 1: [(1, 0), (0, 1)]})
    assert grid.walled_nets() == [0]
    assert sorted(plan_d1(grid, [0, 1])) == [1]

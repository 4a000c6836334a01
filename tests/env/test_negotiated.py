"""The negotiated agent on real boards of the PCBench snapshot (published D3-B test picks), its
copper judged by KiCad: complete and clean where rip-ups are needed, and deterministic."""
from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from tests.helpers import skip_without_snapshot

#: A D3-B pick whose plan needs rip-ups: without them five connections stay open.
RIPPED = "kicad-workshop_fancyboard"
SMALL = "maytal_Maytal"


def _board_id(d3_set, name: str, config: str = "d3-b") -> str:
    found = [p.name for p in (d3_set / config / "test").iterdir() if p.name[5:] == name]
    if not found:
        skip_without_snapshot(f"{d3_set}: no {config} test board {name}")
    return found[0]


def _episode(d3_set, board_id: str, tmp_path, name: str):
    import pcbdata.env
    from pcbdata.agents.negotiated import NegotiatedAgent
    from pcbdata.runners.rollout import run_episode

    env = pcbdata.env.make(d3_set, "d3-b", split="test", drc="terminal")
    try:
        agent = NegotiatedAgent()
        record = run_episode(env, agent, board_id, 0)
        saved = tmp_path / f"{name}.kicad_pcb"
        env.unwrapped.save(saved)
        laid = [item for item in env.unwrapped.board_view().geometry.copper
                if item.kind in ("track", "via")]
        return record, agent.plan, saved.read_bytes(), laid
    finally:
        env.close()


def _view(d3_set, board_id: str, config: str = "d3-b"):
    import pcbdata.env

    env = pcbdata.env.make(d3_set, config, split="test", drc="terminal")
    try:
        env.reset(seed=0, options={"board_id": board_id})
        return env.unwrapped.board_view()
    finally:
        env.close()


def _open_without_rip_ups(d3_set, board_id: str) -> int:
    from pcbdata.agents.negotiated import plan_board

    plan, _ = plan_board(_view(d3_set, board_id), max_rips=0, restarts=0, repair_work=0)
    return len(plan.open)


def _assert_legal(view, plan, connections) -> None:
    """Every planned track and via keeps its clearance to every other net's copper, the
    board's and the plan's (exact shapes, independently of the router), and ends where its
    connection does."""
    import shapely

    from pcbdata.router.geometry import copper_core
    from pcbdata.router.negotiate import NetRule

    static = view.static
    rules = {n.name: NetRule(n.track_width, n.clearance, n.via_diameter, n.via_drill)
             for n in static.nets}
    planned = [item for w in plan.wires.values()
               for item in w.items(rules[w.net], tuple(static.layers))]
    everything = list(view.geometry.copper) + planned
    shapes = [copper_core(item) for item in everything]
    tree = shapely.STRtree([core for core, _ in shapes])
    for k, item in enumerate(planned, start=len(view.geometry.copper)):
        core, radius = shapes[k]
        for j in tree.query(core, predicate="dwithin", distance=radius + 2_000_000):
            other = everything[j]
            if other.net == item.net or not set(other.layers) & set(item.layers):
                continue
            gap = shapely.distance(core, shapes[j][0]) - radius - shapes[j][1]
            assert gap >= max(item.clearance, other.clearance) - 1e-3, (item, other, gap)
    for index, wire in plan.wires.items():
        c = connections[index]
        assert wire.legs[0][1][0] == c.a.at and wire.legs[-1][1][-1] == c.b.at


def test_negotiated_search_frees_what_a_plain_plan_leaves_open(d3_set):
    """On a real board the rip-up search (crossing planned copper at a price, the crossed
    connections ripped and placed again) completes a plan that leaves five connections open
    without it; the plan is legal, uses vias inside its searches, and is the same twice."""
    from pcbdata.agents.negotiated import plan_board

    view = _view(d3_set, _board_id(d3_set, RIPPED))
    plain, _ = plan_board(view, max_rips=0, restarts=0, repair_work=0)
    assert len(plain.open) >= 1
    plan, connections = plan_board(view)
    assert plan.open == {} and plan.stats["rips"] >= 1
    assert plan.stats["repaired"] == 0  # the rounds complete it
    assert any(w.vias for w in plan.wires.values())
    _assert_legal(view, plan, connections)
    again, _ = plan_board(_view(d3_set, _board_id(d3_set, RIPPED)))
    assert again.wires == plan.wires and again.stats == plan.stats
    # the repair after rounds that may not rip up: it lays open connections through the
    # planned copper and places what it rips up again, and leaves fewer open
    repaired, _ = plan_board(view, max_rips=0, restarts=0)
    assert len(repaired.open) < len(plain.open)
    assert repaired.stats["repaired"] == len(plain.open) - len(repaired.open)
    _assert_legal(view, repaired, connections)
    twice, _ = plan_board(view, max_rips=0, restarts=0)
    assert twice.wires == repaired.wires and twice.stats == repaired.stats


@pytest.mark.slow
def test_rip_ups_complete_a_real_board_clean_and_deterministically(d3_set, tmp_path):
    board_id = _board_id(d3_set, RIPPED)
    record, plan, first, laid = _episode(d3_set, board_id, tmp_path, "one")
    assert plan.stats["rips"] >= 1 and plan.open == {}
    assert (record["unconnected"], record["drv"], record["engine_failure"]) == (0, 0, None)
    again, _, second, _ = _episode(d3_set, board_id, tmp_path, "two")
    assert _open_without_rip_ups(d3_set, board_id) > 0  # the rip-ups made the difference
    assert first == second and again["steps"] == record["steps"]
    assert again["reward"] == record["reward"]
    # Two of its planned wires change layer at one point of a net: that via is laid once
    # (a second would be a co-located hole, a warning the strict count counts).
    planned = Counter((w.net, v) for w in plan.wires.values() for v in w.vias)
    assert max(planned.values()) >= 2 and record["agent_report"]["reused_vias"] >= 1
    vias = [(item.net, item.start) for item in laid if item.kind == "via"]
    assert vias and len(vias) == len(set(vias)) == len(planned)


@pytest.mark.slow
def test_negotiated_rollout_through_the_cli_scores_clean(d3_set, tmp_path):
    import json

    from pcbdata.cli import main

    board_id = _board_id(d3_set, SMALL)
    runs = tmp_path / "runs"
    assert main(["rollout", str(d3_set), "--config", "d3-b", "--agent", "negotiated",
                 "--rollouts", "1", "--drc", "terminal", "--workers", "1", "--out",
                 str(runs), "--limit", "1"]) == 0
    record = json.loads((runs / board_id / "0.json").read_text())
    assert (record["agent"], record["unconnected"], record["drv"]) == ("negotiated", 0, 0)
    report = record["agent_report"]  # the plan's counts, kept with the rollout
    assert report["open"] == {"boxed_in": 0, "congestion": 0, "budget": 0}
    assert report["connections"] > 0 and report["refused_wires"] == 0


def test_route_negotiated_on_d2_boards_then_eval(board_set, tmp_path, capsys):
    """`pcbdata route --router negotiated` routes whole boards; `pcbdata eval` scores them."""
    import json

    from pcbdata.cli import main

    runs, report = tmp_path / "runs", tmp_path / "report"
    assert main(["route", str(board_set), "--config", "d2", "--router", "negotiated",
                 "--rollouts", "1", "--workers", "2", "--out", str(runs)]) == 0
    assert "routed 4, failed 0" in capsys.readouterr().out
    assert main(["eval", str(board_set), "--config", "d2", "--runs", str(runs), "--k", "1",
                 "--out", str(report), "--workers", "2"]) == 0
    summary = json.loads((report / "summary.json").read_text())
    assert summary["cp"] == 1.0 and summary["n_boards"] == 4
    assert main(["route", str(board_set), "--config", "d2", "--router", "negotiated",
                 "--router-cmd", "x {dsn} {ses}", "--out", str(tmp_path / "r2")]) == 2


def test_a_pad_whose_centre_is_off_the_board_is_reached_at_an_access_point(d3_set):
    """A D3-C pick's connector pads hang over the board edge: no track can start at their
    centres, so their connections run from the other end to the nearest point of the pad's
    copper where a track may end, and the layered search finds that way on the bare board."""
    from pcbdata.agents.negotiated import plan_board
    from pcbdata.router.negotiate import NetRule, _accessible
    from pcbdata.router.walkaround import WalkaroundRouter

    board_id = _board_id(d3_set, "RGBMatrixPanelCPLD-PhotonBackpack_RGBMatrixPanel_CPLD", "d3-c")
    view = _view(d3_set, board_id, "d3-c")
    _, connections = plan_board(view, budget_routes=0)  # the connections only
    rules = {n.name: NetRule(n.track_width, n.clearance, n.via_diameter, n.via_drill)
             for n in view.static.nets}
    router = WalkaroundRouter(view.geometry)
    moved = [c for c in connections if c.net == "VIN" and c.b.reach == 0]
    assert moved, "no VIN connection to an access point"
    c = moved[0]
    centre = [p for p in view.static.pads if p.net == "VIN" and abs(p.x - c.b.x) <= 2_000_000
              and abs(p.y - c.b.y) <= 2_000_000 and (p.x, p.y) != (c.b.x, c.b.y)]
    assert centre and not router._inside(np.array([[centre[0].x, centre[0].y]], float))[0]
    assert router._inside(np.array([c.b.at], float))[0]
    assert _accessible(router, rules[c.net], c) == c  # an access point stays as it is
    way = router.route_layers(_layered(c, rules[c.net], view.static.layers))
    assert way.legs is not None and way.legs[-1][1][-1] == c.b.at


def _layered(c, rule, layers):
    from pcbdata.router.layered import LayeredRequest

    return LayeredRequest(c.net, c.a.at, c.a.layers, c.b.at, c.b.layers, rule.width,
                          rule.clearance, rule.via_diameter, tuple(layers),
                          (c.a.reach, c.b.reach))


def test_compiled_and_reference_clearance_give_the_same_plan(d3_set, monkeypatch):
    """The plan of a real board that needs rip-ups is the same with the compiled clearance
    test (`pcbdata.router.clearance_kernel`) and without it (PCBDATA_NO_NUMBA=1)."""
    from pcbdata.agents.negotiated import plan_board
    from pcbdata.router import clearance_kernel

    if clearance_kernel.numba is None:
        pytest.skip("numba is not installed (scripts/setup.sh installs it)")
    board_id = _board_id(d3_set, RIPPED)
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "0")
    compiled, _ = plan_board(_view(d3_set, board_id))
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "1")
    reference, _ = plan_board(_view(d3_set, board_id))
    assert compiled.stats["rips"] >= 1
    assert compiled.wires == reference.wires and compiled.open == reference.open
    assert compiled.stats == reference.stats


def test_line_ends_join_a_straight_then_diagonal_pair_into_one_line():
    """`make_line` in mark_obstacles mode lays straight-then-45-degrees to a point, so the
    agent sends one step where the plan's next two segments are that line, and a step per
    corner elsewhere (a diagonal-then-straight pair, three segments)."""
    from pcbdata.agents.negotiated import line_ends

    straight_then_diagonal = [(0, 0), (5, 0), (8, 3)]
    assert line_ends(straight_then_diagonal) == [(8, 3)]
    diagonal_then_straight = [(0, 0), (3, 3), (8, 3)]
    assert line_ends(diagonal_then_straight) == [(3, 3), (8, 3)]
    three = [(0, 0), (5, 0), (8, 3), (8, 9), (10, 11)]
    assert line_ends(three) == [(8, 3), (10, 11)]
    assert line_ends([(0, 0), (4, 4)]) == [(4, 4)] and line_ends([(1, 1)]) == []


def _tracks(laid) -> list[tuple]:
    return sorted((item.net, item.layers, min(item.start, item.end), max(item.start, item.end),
                   item.width) for item in laid if item.kind == "track")


@pytest.mark.slow
def test_joined_lines_lay_the_same_copper_in_fewer_steps(d3_set, tmp_path, monkeypatch):
    """The plan laid with joined straight-then-diagonal lines gives KiCad the same tracks as
    the plan laid corner by corner, in fewer copper-changing steps."""
    import pcbdata.agents.negotiated as negotiated

    board_id = _board_id(d3_set, RIPPED)
    joined, _, _, first = _episode(d3_set, board_id, tmp_path, "joined")
    monkeypatch.setattr(negotiated, "line_ends", lambda path: [tuple(p) for p in path[1:]])
    cornered, _, _, second = _episode(d3_set, board_id, tmp_path, "cornered")
    assert joined["steps"] < cornered["steps"]
    assert (joined["unconnected"], joined["drv"]) == (cornered["unconnected"], cornered["drv"])
    tracks = _tracks(first)
    assert tracks and tracks == _tracks(second)


def test_the_rip_up_search_keeps_vias_off_its_own_nets_planned_vias(d3_set):
    """A real board whose rip-up search (on a board without the copper it may rip up, the
    net's own planned vias among it) put a via over a planned via of its own net, a hole
    KiCad's hole_to_hole forbids: its via spots keep off them, and the plan stays complete."""
    import math
    from itertools import combinations

    from pcbdata.agents.negotiated import plan_board

    view = _view(d3_set, _board_id(d3_set, "ATtiny461Breakout_ATTiny461DevBoard"))
    plan, connections = plan_board(view, seed=2)
    assert plan.open == {} and plan.stats["rips"] >= 1
    diameter = {n.name: n.via_diameter for n in view.static.nets}
    vias = [(w.net, v) for w in plan.wires.values() for v in w.vias]
    assert vias
    for (net, a), (other, b) in combinations(vias, 2):
        if net == other:
            assert math.dist(a, b) == 0 or math.dist(a, b) >= diameter[net], (net, a, b)
    _assert_legal(view, plan, connections)


def test_proofs_that_no_path_exists_change_no_way_and_save_work(d3_set):
    """On a real board whose plan has searches that find nothing, the proofs that a search's
    ends lie in separate parts of the free space (`WalkaroundRouter.prove_separation`) leave
    every way, open connection and rip-up of the plan as it is and cut its counted work."""
    from pcbdata.agents.negotiated import plan_board

    view = _view(d3_set, _board_id(d3_set, RIPPED))
    proving, _ = plan_board(view)
    plain, _ = plan_board(view, prove_separation=False)
    assert proving.wires == plain.wires and proving.open == plain.open
    assert proving.stats["rips"] == plain.stats["rips"] >= 1
    assert proving.stats["work"] < 0.6 * plain.stats["work"]

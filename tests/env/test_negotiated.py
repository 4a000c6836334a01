"""The negotiated agent on real boards of the PCBench snapshot (published D3-B test picks), its
copper judged by KiCad: complete and clean where rip-ups are needed, and deterministic."""
from __future__ import annotations

import pytest

from tests.helpers import skip_without_snapshot

#: A D3-B pick whose plan needs rip-ups (two connections ripped and placed again).
RIPPED = "ATtiny461Breakout_ATTiny461DevBoard"
SMALL = "maytal_Maytal"


def _board_id(d3_set, name: str) -> str:
    found = [p.name for p in (d3_set / "d3-b" / "test").iterdir() if p.name[5:] == name]
    if not found:
        skip_without_snapshot(f"{d3_set}: no D3-B test board {name}")
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
        return record, agent.plan, saved.read_bytes()
    finally:
        env.close()


def _open_without_rip_ups(d3_set, board_id: str) -> int:
    import pcbdata.env
    from pcbdata.agents.negotiated import plan_board

    env = pcbdata.env.make(d3_set, "d3-b", split="test", drc="terminal")
    try:
        env.reset(seed=0, options={"board_id": board_id})
        plan, _ = plan_board(env.unwrapped.board_view(), max_rips=0, restarts=0)
        return len(plan.open)
    finally:
        env.close()


@pytest.mark.slow
def test_rip_ups_complete_a_real_board_clean_and_deterministically(d3_set, tmp_path):
    board_id = _board_id(d3_set, RIPPED)
    record, plan, first = _episode(d3_set, board_id, tmp_path, "one")
    assert plan.stats["rips"] >= 1 and plan.open == {}
    assert (record["unconnected"], record["drv"], record["engine_failure"]) == (0, 0, None)
    again, _, second = _episode(d3_set, board_id, tmp_path, "two")
    assert _open_without_rip_ups(d3_set, board_id) > 0  # the rip-ups made the difference
    assert first == second and again["steps"] == record["steps"]
    assert again["reward"] == record["reward"]


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

"""The paper's protocol on real boards judged by KiCad: the session's text, tags and counts on a
D2 board, start_route while routing, and `pcbdata rollout --agent llm-paper | llm-paper-plan |
llm-paper-direct` against the replaying chat-completions server on 127.0.0.1
(`tests/env/paper_replay.py`) on D2 boards and a D3-A board (with the PCBench snapshot).

The server replays replies the scripted stand-in gave in the paper's protocol, one malformed
or refused reply of every shape first: the rollouts, run in worker processes, must end with
the recording's reward, every idle reply counted by kind, and the token split recorded."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from pcbdata.cli import main
from pcbdata.core.tree import list_instances
from pcbdata.env.llm.paper import IDLE_KINDS, PaperSession
from tests.env.paper_replay import BAD_REPLIES, PaperReplayServer, record_paper

BOARDS = ["board_00000", "board_00001"]
#: One bad reply of every kind at steps 1..13, then the mask miss again (merged with it).
BAD = {i + 1: reply for i, reply in enumerate(BAD_REPLIES.values())}
BAD[len(BAD) + 1] = BAD_REPLIES["mask"]


@pytest.fixture(scope="module")
def recording(board_set, tmp_path_factory):
    return record_paper(board_set, "d2", BOARDS, tmp_path_factory.mktemp("paper"), bad=BAD)


def test_the_session_text_tags_and_counts(recording, board_set, tmp_path):
    rec = recording[BOARDS[0]]
    counts = rec["counts"]
    assert {k: counts[k] for k in IDLE_KINDS} == {k: 2 if k == "mask" else 1
                                                  for k in IDLE_KINDS}
    assert counts["turns"] == len(rec["replies"]) == counts["accepted"] + len(BAD)
    messages = rec["messages"]  # messages[k]: the user message of step k + 1
    assert all(m.isascii() for m in [rec["static"], *messages])
    assert "(pad P0 N0 (at " in rec["static"] and "(board_constraints (clearance " in \
        rec["static"]
    first = messages[0]
    assert first.startswith("## Step 1\n(routing_geometry\n") and "candidate" not in first
    assert "(router_head (phase no_net) (mode w))" in first
    assert "## Valid actions\nnet_select\n" in first
    before_accept = messages[len(BAD)]  # after the 14 bad replies: all listed, one merged
    assert "Step 1: [empty reply] (rejected x1)" in before_accept
    assert "Step 13-14: make_line 10.000 10.000 w (rejected x2)" in before_accept
    assert "Step 2: [missing action] (rejected x1)" in before_accept
    assert "## History (step 15, valid steps 0)\n(none)" in before_accept
    after_accept = messages[len(BAD) + 3]
    assert "## Rejected attempts\n(none)" in after_accept  # cleared by an accepted action
    history = after_accept.split("## History")[1].split("## Rejected")[0]
    assert history.count("<action>") == 2  # the last two turns
    assert re.search(r"Step 17: <think>scripted step 17</think><action>\S", history)
    tagged = [m for m in messages if "[no effect]" in m]
    assert tagged, "the stand-in's vias beside a pad leave the open count as it was"
    assert all(len(re.findall(r"-?\d+\.\d+", m)) == len(re.findall(r"-?\d+\.\d{3}\b", m))
               for m in messages)  # every decimal written with three decimals
    again = record_paper(board_set, "d2", BOARDS[:1], tmp_path, bad=BAD)[BOARDS[0]]
    assert again["messages"] == messages and again["reward"] == rec["reward"]


def test_start_route_while_routing_moves_the_head(make_env):
    env = make_env("d2", drc="terminal")
    session = PaperSession(env)
    session.reset(seed=0, options={"board_id": "board_00001"})
    static = env.unwrapped.static
    net = next(i for i, n in enumerate(static.nets) if len(static.pads_of(n.name)) == 2)
    pad = static.pads[static.pads_of(static.nets[net].name)[0]]
    layer = "1" if 0 in pad.layers else "2"
    x, y = pad.x / 1e6, pad.y / 1e6
    via_x = x + 2.0 if x + 2.0 < 100 else x - 2.0  # the worked example: a via 2 mm away
    steps = [f"net_select N{net}", f"start_route {x:.3f} {y:.3f} {layer}",
             f"make_via {via_x:.3f} {y:.3f} w"]
    for body in steps:
        *_, outcome = session.step(f"<think>t</think><action>{body}</action>")
        assert outcome.accepted, (body, outcome)
    head = env.unwrapped._head
    if (head.x, head.y) != (round(via_x * 1e6), pad.y):
        pytest.skip("the walkaround found no way to the via point on this board")
    other = "2" if layer == "1" else "1"
    *_, outcome = session.step(f"<think>t</think><action>start_route {via_x:.3f} {y:.3f} "
                               f"{other}</action>")
    assert outcome.accepted and session.info["phase"] == "routing"
    assert env.unwrapped._head.layer == session.ids.layer_index(other)
    *_, outcome = session.step(f"<think>t</think><action>start_route {x + 0.5:.3f} {y:.3f} "
                               f"{layer}</action>")  # no anchor there: a mask miss
    assert outcome.kind == "mask" and "is no pad centre" in outcome.reason
    assert session.counts["accepted"] == 4 and session.counts["mask"] == 1


def _rollout(board_set, runs, agent, url, config="d2", *extra) -> list[str]:
    return ["rollout", str(board_set), "--config", config, "--split", "test", "--agent", agent,
            "--out", str(runs), "--workers", "1", "--drc", "terminal", "--base-url", url,
            "--model", "replay", *extra]


def test_rollouts_against_the_replay_server_on_d2(board_set, recording, tmp_path, capsys):
    bare = {b: (board_set / "d2" / "test" / b / "board.kicad_pcb").read_text("utf-8")
            for b in BOARDS}
    runs = {agent: tmp_path / agent for agent in ("llm-paper", "llm-paper-plan",
                                                  "llm-paper-direct")}
    with PaperReplayServer(recording, bare) as server:
        assert main(_rollout(board_set, runs["llm-paper"], "llm-paper", server.url,
                             "d2", "--limit", "2")) == 0
        bodies = [r["body"] for r in server.requests]
        measures = len(server.measures)
    assert "ended: terminated" in capsys.readouterr().out
    assert measures == 2  # the system message, once per episode
    assert all(b["max_tokens"] == 256 and "tools" not in b and len(b["messages"]) == 2
               for b in bodies)
    for board in BOARDS:
        rec = json.loads((runs["llm-paper"] / board / "0.json").read_text())
        assert rec["reward"] == pytest.approx(recording[board]["reward"], abs=1e-9)
        report, llm = rec["agent_report"], rec["llm"]
        assert report["idle"] == {k: 2 if k == "mask" else 1 for k in IDLE_KINDS}
        assert report["idle_total"] == len(BAD) and report["turns"] == rec["steps"]
        assert llm["accounting"]["parse_failures"] == len(BAD) - 2
        assert llm["prompt_version"] == "paper-llm-1" and llm["end"] == "terminated"
        assert llm["options"]["protocol"]["turns"] == 200
        acc = llm["accounting"]
        assert acc["tokens_measured_by"] == ("usage of a request that sends the system "
                                             "message alone")
        assert acc["system_tokens"] == acc["system_tokens_per_request"] * rec["steps"]
        assert acc["system_tokens"] + acc["user_tokens"] == acc["prompt_tokens"] - \
            acc["system_tokens_per_request"]  # the measuring request is not a turn
        assert acc["response_tokens"] > 0 and rec["agent_identity"]["name"] == "llm-paper"
    with PaperReplayServer(recording, bare, tokenize=True) as server:
        assert main(_rollout(board_set, runs["llm-paper-plan"], "llm-paper-plan", server.url,
                             "d2", "--limit", "2")) == 0
        assert main(_rollout(board_set, runs["llm-paper-direct"], "llm-paper-direct",
                             server.url, "d2", "--limit", "1")) == 0
    for board in BOARDS:
        rec = json.loads((runs["llm-paper-plan"] / board / "0.json").read_text())
        assert rec["reward"] == pytest.approx(recording[board]["reward"], abs=1e-9)
        assert rec["agent_report"]["plan_lines"] == len(recording[board]["bodies"])
        assert rec["agent_report"]["idle_total"] == 0
        assert rec["llm"]["accounting"]["tokens_measured_by"].startswith("tokenize route")
    direct = json.loads((runs["llm-paper-direct"] / BOARDS[0] / "0.json").read_text())
    assert direct["agent_report"]["items"] > 0 and direct["agent_report"]["text_problem"] is None
    assert direct["agent_report"]["off_octilinear_segments"] == 0
    report = tmp_path / "report"
    assert main(["eval", str(board_set), "--config", "d2", "--split", "test", "--runs",
                 str(runs["llm-paper-direct"]), "--out", str(report), "--k", "1",
                 "--workers", "1", "--limit", "1"]) == 0
    summary = json.loads((report / "summary.json").read_text())
    assert summary["llm"]["rollouts"] == 1 and summary["llm"]["user_tokens"] > 0


def test_rollout_on_a_d3a_board(d3_set, tmp_path):
    board = next(iter(list_instances(Path(d3_set), "d3-a", "test")))[0]
    bad = {2: BAD_REPLIES["missing_think"], 3: BAD_REPLIES["mask"], 4: BAD_REPLIES["number"]}
    turns = 24
    recording = record_paper(Path(d3_set), "d3-a", [board], tmp_path, bad=bad, turns=turns)
    runs = tmp_path / "runs"
    extra = 'extra_body={"chat_template_kwargs": {"enable_thinking": false}, "temperature": null}'
    with PaperReplayServer(recording) as server:
        assert main(_rollout(d3_set, runs, "llm-paper", server.url, "d3-a", "--limit", "1",
                             "--llm-option", f"turns={turns}", "--llm-option",
                             "chat_history=true", "--llm-option", extra)) == 0
        bodies = [r["body"] for r in server.requests]
        measure = server.measures[0]
    assert measure["max_tokens"] == 1 and "temperature" not in measure
    assert all(b["chat_template_kwargs"] == {"enable_thinking": False} and "temperature" not in b
               for b in bodies)
    # earlier turns as chat messages: system, the last two (user, assistant) pairs, user
    assert [len(b["messages"]) for b in bodies[:4]] == [2, 4, 6, 6]
    assert bodies[2]["messages"][2]["content"] == recording[board]["replies"][0]
    rec = json.loads((runs / board / "0.json").read_text())
    assert rec["reward"] == pytest.approx(recording[board]["reward"], abs=1e-9)
    idle = rec["agent_report"]["idle"]
    assert idle["missing_think"] == 1 and idle["number"] == 1 and idle["mask"] >= 1
    assert rec["steps"] <= turns and rec["llm"]["options"]["protocol"]["turns"] == turns
    assert "(board_static (board " in recording[board]["static"]


@pytest.mark.parametrize("failure", ["skip_net", "continue"])
def test_a_failing_plan_line_skips_the_rest_of_its_net(recording, make_env, failure):
    from pcbdata.agents.llm_paper import PaperPlanAgent

    bodies = list(recording[BOARDS[0]]["bodies"])
    first_end = bodies.index("net_end")
    broken = [*bodies[:2], "make_line 1,500 2.000 w", *bodies[2:]]  # after the first start_route
    plan = {BOARDS[0]: dict(recording[BOARDS[0]], bodies=broken)}
    env = make_env("d2", drc="terminal")
    with PaperReplayServer(plan) as server:
        agent = PaperPlanAgent(seed=0, base_url=server.url, model="replay",
                               plan_failure=failure)
        record = agent.episode(env, BOARDS[0], 0, {})
    report = record["agent_report"]
    assert report["plan_lines"] == len(broken) and report["idle"]["number"] == 1
    if failure == "continue":
        assert report["skipped_lines"] == 0 and record["unconnected"] == 0
        assert record["reward"] == pytest.approx(recording[BOARDS[0]]["reward"], abs=1e-9)
    else:  # the first net's remaining lines are not replayed; its net_end releases it
        assert report["skipped_lines"] == first_end - 2
        assert record["unconnected"] > 0 and record["steps"] == len(broken) - \
            report["skipped_lines"]

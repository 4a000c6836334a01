"""The paper's protocol without KiCad (about a second): the reply parser on every reply shape
of SPEC 7.2, action bodies both ways, plan lines, engine-free items, the protocol options
and the token measurement against the replay server on 127.0.0.1."""
from __future__ import annotations

import argparse

import pytest

from pcbdata.agents.llm_paper import (
    PAPER_DEFAULTS,
    PaperAgent,
    off_octilinear,
    paper_items,
    paper_options,
    plan_lines,
    repair_items,
)
from pcbdata.cli.rollout import _name_value, llm_options
from pcbdata.core.errors import UserError
from pcbdata.env.llm.paper import BODY, IDLE_KINDS, Ids, action_body, read_body, read_reply
from pcbdata.env.types import (
    FINISH,
    MAKE_LINE,
    MAKE_VIA,
    MARK_OBSTACLES,
    NET_END,
    NET_SELECT,
    PUSH_N_SHOVE,
    START_ROUTE,
    WALKAROUND,
)
from tests.env.paper_replay import BAD_REPLIES, PaperReplayServer

IDS = Ids({"net_names": ["GND", "NET-(R1-Pad1)", "VCC"], "layers": ["F.Cu", "In1.Cu",
                                                                    "In2.Cu", "B.Cu"]})


def _reply(body: str, think: str = "ok") -> str:
    return f"<think>{think}</think><action>{body}</action>"


@pytest.mark.parametrize("kind", [k for k in BAD_REPLIES if k != "mask"])
def test_every_malformed_reply_shape_is_idle_with_its_kind(kind):
    parsed = read_reply(BAD_REPLIES[kind], IDS)
    assert parsed.action is None and parsed.kind == kind and parsed.reason
    assert kind in IDLE_KINDS


@pytest.mark.parametrize("reply, kind", [
    (None, "empty_reply"),
    ("   \n", "empty_reply"),
    ("<think>x</think><action>net_end", "missing_action"),  # cut by the token cap
    ("<action>net_end</action><think>late</think>", "missing_think"),
    (_reply("net_select N9"), "mask"),  # no such net: a mask miss after a good parse
    (_reply("net_select 3"), "mask"),
    (_reply("make_line 1e3 2.0 w"), "number"),
    (_reply("make_line .5 2.0 w"), "number"),
    (_reply("start_route 1.0 2.0 F.Cu"), "bad_layer"),
    (_reply("make_via 1.0 2.0 walkaround"), "bad_mode"),
    (_reply("finish"), "arity"),
    (_reply("net_end now"), "arity"),
    (_reply("idle"), "unknown_verb"),
    (_reply("Make_line 1.0 2.0 w"), "unknown_verb"),
])
def test_more_replies_that_become_idle(reply, kind):
    assert read_reply(reply, IDS).kind == kind


@pytest.mark.parametrize("body, action", [
    ("net_select N1", {"type": NET_SELECT, "net": 1}),
    ("net_select GND", {"type": NET_SELECT, "net": 0}),  # an exact name is read too
    ("net_end", {"type": NET_END}),
    ("start_route 12.345 6.789 1", {"type": START_ROUTE, "x": 12.345, "y": 6.789, "layer": 0}),
    ("start_route -1.5 0 2", {"type": START_ROUTE, "x": -1.5, "y": 0.0, "layer": 3}),
    ("make_line 12.345 6.789 w", {"type": MAKE_LINE, "x": 12.345, "y": 6.789,
                                  "mode": WALKAROUND}),
    ("make_via 10.0 9.5 p", {"type": MAKE_VIA, "x": 10.0, "y": 9.5, "mode": PUSH_N_SHOVE}),
    ("finish m", {"type": FINISH, "mode": MARK_OBSTACLES}),
])
def test_the_six_verbs_as_free_coordinate_actions(body, action):
    parsed = read_reply(_reply(body, "reason first"), IDS)
    assert parsed.kind is None and parsed.action == action and parsed.body == body
    assert parsed.think == "reason first" and BODY.match(parsed.body)


def test_whitespace_inside_the_action_is_normalised_and_text_around_is_ignored():
    parsed = read_reply("Sure.\n<think>\nline one\n</think>\n<action>\n make_line  1.000\t2.000 "
                        "w \n</action>\nDone.", IDS)
    assert parsed.body == "make_line 1.000 2.000 w" and parsed.think == "line one"


def test_without_require_think_a_bare_action_is_read():
    assert read_reply("<action>net_end</action>", IDS, require_think=False).action == \
        {"type": NET_END}


def test_action_bodies_round_trip():
    for body in ("net_select N2", "net_end", "start_route 1.000 2.000 2", "finish p",
                 "make_line 3.500 -4.250 m", "make_via 0.000 0.500 w"):
        action = read_body(body, IDS).action
        assert action is not None and action_body(action, IDS) == body


def test_plan_lines_and_engine_free_items():
    assert plan_lines("x <actions>\nnet_select N0\n\n  net_end \n</actions> y") == \
        ["net_select N0", "net_end"]
    assert plan_lines("net_select N0") is None and plan_lines(None) is None
    text = ('(segment (start 0 0) (end 3 3) (width 0.25) (layer "F.Cu") (net 1))\n'
            '(segment (start 3 3) (end 10 3.0001) (width 0.25) (layer "F.Cu") (net 1))\n'
            '(arc (start 0 0) (mid 1 1) (end 2 0) (width 0.25) (layer "F.Cu") (net 1))\n'
            '(via (at 10 3) (size 0.6) (drill 0.3) (layers "F.Cu" "B.Cu") (net 1))')
    items, dropped = paper_items(text)
    assert [i.split()[0] for i in items] == ["(segment", "(segment", "(via"] and dropped == 1
    assert off_octilinear(items) == 1


def test_protocol_options_and_their_checks():
    merged, client = paper_options({"turns": 5, "model": "m", "base_url": "http://x/v1"})
    assert merged == {**PAPER_DEFAULTS, "turns": 5} and client == {"model": "m",
                                                                   "base_url": "http://x/v1"}
    for bad in ({"turns": 0}, {"history": -1}, {"no_effect": "some"},
                {"system_tokens": "guess"}, {"chat_history": "yes"},
                {"plan_failure": "abort"}, {"plan_max_steps": 0}, {"extra_body": [1]},
                {"extra_body": {"model": "other"}}, {"board_first": 1},
                {"direct_repair": "yes"}):
        with pytest.raises(UserError):
            paper_options(bad)
    assert _name_value("turns=40") == ("turns", 40)
    assert _name_value("chat_history=true") == ("chat_history", True)
    assert _name_value("no_effect=all") == ("no_effect", "all")
    with pytest.raises(UserError):
        _name_value("turns")
    args = argparse.Namespace(agent="llm", llm_protocol=["turns=3"],
                              **{f"llm_{d}": None for d in ("base_url", "model", "api_key_env",
                                                            "temperature", "seed", "max_tokens",
                                                            "timeout_s", "max_retries",
                                                            "backoff_s", "backoff_cap_s")})
    with pytest.raises(UserError, match="for the paper's agents"):
        llm_options(args)


@pytest.mark.parametrize("tokenize, how, measured_by", [
    (True, "auto", "tokenize route (messages, chat template)"),
    (False, "auto", "usage of a request that sends the system message alone"),
    (False, "request", "usage of a request that sends the system message alone"),
    (False, "tokenize", "not measured: no tokenize route"),
    (True, "off", "not measured (system_tokens=off)"),
])
def test_the_system_message_is_measured_once(tokenize, how, measured_by):
    system = "s" * 400  # 100 tokens at the server's 4 characters per token
    with PaperReplayServer({}, tokenize=tokenize) as server:
        agent = PaperAgent(seed=0, base_url=server.url, model="replay", system_tokens=how)
        agent._measure(system)
        measures, tokenized = len(server.measures), len(server.tokenized)
    assert agent.measured_by.startswith(measured_by)
    expected = None if measured_by.startswith("not") else 100
    assert agent.system_per_request == expected
    assert measures == (measured_by.startswith("usage")) and tokenized == (tokenize and how
                                                                            != "off")
    agent.with_usage, agent.prompt_sum, agent.response_sum = 3, 450, 30
    split = agent._token_split()
    if expected is not None:
        assert split["system_tokens"] == 300 and split["user_tokens"] == 150
        assert split["total_tokens"] == 480 and split["response_tokens"] == 30
    else:
        assert split["system_tokens"] is None and split["user_tokens"] is None


def test_engine_free_items_repaired_from_their_nets_rules():
    rules = {"1": ("0.250", "0.600", "0.300")}
    items = ['(segment (start 0 0) (end 1 0) (layer "F.Cu") (net 1))',
             '(segment (start 0 0) (end 1 0) (width 0.2) (layer "F.Cu") (net 1))',
             "(via (at 1 0) (net 1))", '(segment (start 0 0) (end 1 0) (layer "F.Cu") (net 7))']
    out, changed = repair_items(items, rules)
    assert changed == 2 and out[1:] == [items[1], out[2], items[3]]
    assert out[0] == '(segment (start 0 0) (end 1 0) (layer "F.Cu") (net 1) (width 0.250))'
    assert out[2] == '(via (at 1 0) (net 1) (size 0.600) (drill 0.300) (layers "F.Cu" "B.Cu"))'

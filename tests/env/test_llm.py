"""The language-model wrapper (`pcbdata.env.llm.wrapper`): tool schema, strict reply parser, text of
the board, history and streak lines, and whole episodes driven by a scripted stand-in model
(valid, malformed and masked replies) on a D2 board, scored by the evaluator. No network."""
from __future__ import annotations

import json
import math
import re

import pytest

from pcbdata.agents.llm_standin import ScriptedModel, as_reply
from pcbdata.env.llm.tools import VERBS, parse_reply, tool_schema
from pcbdata.env.llm.wrapper import STOP, LLMWrapper, run_episode
from pcbdata.env.types import (
    FINISH,
    IDLE,
    MAKE_LINE,
    MAKE_VIA,
    MODES,
    NET_END,
    NET_SELECT,
    START_ROUTE,
)

NETS = ["GND", "Net-(R1-Pad1)", "VCC"]
SLOTS = 64


def _tool(name: str, arguments) -> dict:
    return {"role": "assistant", "content": "",
            "tool_calls": [{"id": "c1", "type": "function",
                            "function": {"name": name, "arguments": arguments}}]}


# ---- the tool schema -----------------------------------------------------------------------
def test_tool_schema_has_one_json_schema_function_per_operation():
    tools = tool_schema(SLOTS)
    assert [t["function"]["name"] for t in tools] == list(VERBS) == [
        "net_select", "net_end", "start_route", "make_line", "make_via", "finish"]
    json.dumps(tools)  # plain JSON, as chat APIs take it
    by_name = {t["function"]["name"]: t["function"] for t in tools}
    for tool in tools:
        assert tool["type"] == "function"
        function = tool["function"]
        assert function["description"]
        parameters = function["parameters"]
        assert parameters["type"] == "object" and parameters["additionalProperties"] is False
        assert set(parameters["required"]) <= set(parameters["properties"])
    assert by_name["net_end"]["parameters"]["properties"] == {}
    assert by_name["net_select"]["parameters"]["properties"]["net"]["type"] == "string"
    point = by_name["make_line"]["parameters"]["properties"]["point"]
    assert (point["type"], point["minimum"], point["maximum"]) == ("integer", 0, SLOTS - 1)
    for verb in ("make_line", "make_via", "finish"):
        mode = by_name[verb]["parameters"]["properties"]["mode"]
        assert mode["enum"] == ["walkaround", "mark_obstacles", "push_n_shove"]
        assert mode["default"] == "walkaround"
        assert "mode" not in by_name[verb]["parameters"]["required"]
    assert by_name["start_route"]["parameters"]["required"] == ["point"]


# ---- the parser --------------------------------------------------------------------------------
@pytest.mark.parametrize("reply, call, action", [
    ("make_line(3, walkaround)", "make_line(3, walkaround)", (MAKE_LINE, 0, 3, 0)),
    ("  `make_via(7, mark_obstacles)`\n", "make_via(7, mark_obstacles)", (MAKE_VIA, 0, 7, 1)),
    ("make_line(point=5)", "make_line(5, walkaround)", (MAKE_LINE, 0, 5, 0)),
    ("finish()", "finish(walkaround)", (FINISH, 0, 0, 0)),
    ("net_end()", "net_end()", (NET_END, 0, 0, 0)),
    ('net_select("Net-(R1-Pad1)")', 'net_select("Net-(R1-Pad1)")', (NET_SELECT, 1, 0, 0)),
    ("net_select(VCC)", 'net_select("VCC")', (NET_SELECT, 2, 0, 0)),
    (_tool("start_route", '{"point": 12}'), "start_route(12)", (START_ROUTE, 0, 12, 0)),
    (_tool("finish", '{"mode": "mark_obstacles"}'), "finish(mark_obstacles)", (FINISH, 0, 0, 1)),
    (_tool("net_end", ""), "net_end()", (NET_END, 0, 0, 0)),
    ({"name": "net_select", "arguments": {"net": "GND"}}, 'net_select("GND")',
     (NET_SELECT, 0, 0, 0)),
    ({"role": "assistant", "content": "make_line(63)"}, "make_line(63, walkaround)",
     (MAKE_LINE, 0, 63, 0)),
])
def test_parser_reads_each_accepted_shape(reply, call, action):
    parsed = parse_reply(reply, NETS, SLOTS)
    assert parsed.reason is None and parsed.call == call
    assert tuple(parsed.action[k] for k in ("type", "net", "candidate", "mode")) == action


BAD = [
    ("make_line(3); finish()", "2 calls in one reply"),
    ("make_line(3)\nmake_line(4)", "2 calls in one reply"),
    ({"tool_calls": [{"function": {"name": "finish", "arguments": "{}"}}] * 2},
     "2 tool calls: send exactly one action"),
    ("route_everything()", "unknown verb 'route_everything'"),
    ("idle()", "idle is not a verb"),
    (_tool("teleport", "{}"), "unknown verb 'teleport'"),
    ("net_end(3)", "net_end takes no arguments, got 1"),
    ("make_line()", "make_line takes (point, mode=walkaround), got 0"),
    ("make_line(3,)", "an argument is missing after the last comma"),
    ("make_line(1, walkaround, 3)", "make_line takes (point, mode=walkaround), got 3"),
    (_tool("make_line", '{"point": 1, "speed": 2}'), "unknown argument(s) ['speed']"),
    (_tool("start_route", "{}"), "start_route: missing argument(s) ['point']"),
    ("make_line(3, walkarö)", "non-ASCII character U+00F6 at position 19"),
    (_tool("net_select", '{"net": "GNÐ"}'), "non-ASCII character"),
    (_tool("make_line", '{"point": 3'), "make_line: arguments are not valid JSON"),
    (_tool("make_line", "[3]"), "arguments must be a JSON object"),
    ("start_route(64)", "start_route: point 64 out of range [0, 64)"),
    ("start_route(-1)", "point -1 out of range"),
    (_tool("make_line", '{"point": 2.5}'), "point must be an integer candidate index, got 2.5"),
    (_tool("make_line", '{"point": true}'), "point must be an integer"),
    ("make_line(three)", "point must be an integer"),
    ("make_via(2, sideways)", 'unknown mode "sideways"'),
    ('net_select("NO_SUCH_NET")', 'net_select: unknown net "NO_SUCH_NET"'),
    ("net_select(gnd)", 'unknown net "gnd"'),
    ("I will route net GND now.", "not a call"),
    ("Sure! make_line(3)", "not a call"),
    ("make_line(point=3, walkaround)", "either positional or keyword"),
    ("", "empty reply"),
    (None, "expected text or a tool call, got NoneType"),
    ({"content": None, "tool_calls": []}, "no tool call and no text"),
    ({"tool_calls": "finish()"}, "tool_calls must be a list"),
]


@pytest.mark.parametrize("reply, reason", BAD)
def test_parser_turns_anything_else_into_idle_with_the_reason(reply, reason):
    parsed = parse_reply(reply, NETS, SLOTS)
    assert parsed.action == {"type": IDLE, "net": 0, "candidate": 0, "mode": 0}
    assert parsed.call == ""
    assert parsed.reason is not None and reason in parsed.reason, parsed.reason
    assert "\n" not in parsed.reason


def test_reply_round_trip_through_every_shape():
    for action in ({"type": NET_SELECT, "net": 1}, {"type": NET_END},
                   {"type": START_ROUTE, "candidate": 9},
                   {"type": MAKE_LINE, "candidate": 4, "mode": 1},
                   {"type": MAKE_VIA, "candidate": 0}, {"type": FINISH, "mode": 0}):
        for style in ("text", "tool_calls", "bare"):
            parsed = parse_reply(as_reply(action, NETS, style), NETS, SLOTS)
            assert parsed.reason is None
            assert all(parsed.action[k] == v for k, v in action.items()), (action, style)


# ---- episodes with the scripted stand-in -------------------------------------------------------
#: Replies sent before the stand-in plays, with the reason each gets. The first is masked
#: (no net is selected): the environment refuses it; the others the parser refuses.
OPENING = [
    ("make_line(0, walkaround)", "make_line is masked in phase no_net"),
    ("make_line(3); finish()", "2 calls in one reply"),
    ({"tool_calls": [{"function": {"name": "finish", "arguments": "{}"}}] * 2}, "2 tool calls"),
    ("route_all()", "unknown verb 'route_all'"),
    ("net_end(3)", "net_end takes no arguments"),
    ("finish(walkaroünd)", "non-ASCII character"),
    ({"name": "make_line", "arguments": "{point: 3"}, "not valid JSON"),
    ("start_route(64)", "point 64 out of range [0, 64)"),
    ('net_select("NO_SUCH_NET")', 'unknown net "NO_SUCH_NET"'),
    ("finish(push_n_shove)", "finish is masked in phase no_net"),
]
TURNS = 3


class InjectingModel:
    """The opening's bad replies, then the stand-in; after the stand-in's first net_select it
    sends that call again (allowed, but nothing changes); after one routing step of its own it
    sends a make_line in a masked mode (push_n_shove today, or an empty slot if it is
    available). Records every message list it is given."""

    def __init__(self, wrapper: LLMWrapper):
        self.standin = ScriptedModel(wrapper, style="alternate")
        self.wrapper = wrapper
        self.pending = [reply for reply, _ in OPENING]
        self.seen: list[list[dict]] = []
        self.repeated = self.masked_mode = False
        self.masked_reply = ""

    def __call__(self, messages, tools):
        assert tools == self.wrapper.tools
        assert len(messages) <= 2 * TURNS + 2
        self.seen.append([dict(m) for m in messages])
        if self.pending:
            return self.pending.pop(0)
        reply = self.standin(messages, tools)
        call = parse_reply(reply, self.wrapper.net_names, 64).call if reply != STOP else ""
        if call.startswith("net_select") and not self.repeated:
            self.repeated = True
            self.pending.append(reply)
        elif call.startswith("finish") and not self.masked_mode:
            self.masked_mode = True
            self.masked_reply = self._masked_line()
            self.pending.append(self.masked_reply)
        return reply

    def _masked_line(self) -> str:
        mask = self.wrapper.last_info["action_mask"]
        if not mask["mode"][2]:
            return "make_line(0, push_n_shove)"
        empty = next(i for i in range(64) if not mask["candidate"][i])
        return f"make_line({empty}, walkaround)"


def _episode(make_env, **options):
    env = make_env("d2", counting="evaluation", router_nodes=1, **options)
    wrapper = LLMWrapper(env, history=6, turns=TURNS, streak_from=2)
    model = InjectingModel(wrapper)
    # board 1 with a one-node search budget: one finish finds no path (a no-effect step)
    result = run_episode(wrapper, model, seed=0, options={"index": 1})
    return env, wrapper, model, result


SEXPR_NUMBER = re.compile(r"-?\d+\.\d+")


def _sexpr_parts(message: str) -> str:
    """The s-expression part of a message (before the "Allowed now" line)."""
    return message.split("\nAllowed now:")[0] if message.startswith("(state") else \
        message[message.index("(board "):]


def test_scripted_episode_paths_history_streak_and_score(board_set, make_env, kicad_pool, tmp_path):
    from pcbdata.evaluator import score

    env, wrapper, model, result = _episode(make_env)
    records = result.records
    assert result.terminated and not result.stopped and result.unconnected == 0
    assert result.steps == len(records) == len(model.seen)

    # every opening reply: refused with its reason, idle (or the masked action) sent, no reward
    for record, (reply, reason) in zip(records, OPENING, strict=False):
        assert record.reply == reply
        assert record.reason and reason in record.reason, (reason, record.reason)
        assert record.outcome == f"rejected: {record.reason}"
        assert record.reward == 0.0
    assert records[0].call == "make_line(0, walkaround)"  # read, then masked by the env
    assert records[1].call == "" and records[1].action["type"] == IDLE

    # the next message tells the model why, marks the history, and counts the streak
    after_first, after_third = model.seen[1][-1]["content"], model.seen[3][-1]["content"]
    assert "Your last reply: rejected: make_line is masked in phase no_net" in after_first
    assert "rejected replies in a row" not in after_first
    assert "step 1: make_line(0, walkaround) -> rejected: make_line is masked" in after_third
    assert 'step 2: <bad reply: make_line(3); finish()> -> rejected: 2 calls' in after_third
    assert "3 rejected replies in a row" in after_third
    last_opening = model.seen[len(OPENING)][-1]["content"]
    assert f"{len(OPENING)} rejected replies in a row" in last_opening
    assert last_opening.count("\n  step ") == 6  # the history keeps the last 6 actions

    # the stand-in's first reply is accepted: the streak line goes
    first_ok = len(OPENING)
    assert records[first_ok].outcome == "ok" and records[first_ok].call.startswith("net_select")
    assert "in a row" not in model.seen[first_ok + 1][-1]["content"]

    # the repeated net_select, the router failure and the masked mode are marked
    outcomes = [r.outcome for r in records]
    assert outcomes[first_ok + 1] == "no effect: nothing changed"
    assert any(o.startswith("no effect: router failed (finish: no path") for o in outcomes)
    masked = next(r for r in records if r.reply == model.masked_reply)
    assert re.fullmatch(r"rejected: make_line: (mode push_n_shove: .+|candidate \d+ is masked)",
                        masked.outcome), masked.outcome
    texts = [m[-1]["content"] for m in model.seen]
    assert any("-> no effect: nothing changed" in t for t in texts)
    assert any("-> no effect: router failed" in t for t in texts)

    # allowed verbs come from the masks
    assert "Allowed now: net_select(net)." in texts[0]
    assert "Allowed now: net_select(net), net_end(), start_route(point)." in texts[first_ok + 1]
    modes = [m for m, on in zip(MODES, env.unwrapped.action_masks()["mode"], strict=True) if on]
    assert f"Modes: {', '.join(modes)}." in texts[0]

    # the saved board scores as the episode says
    saved = tmp_path / "llm.kicad_pcb"
    env.unwrapped.save(saved)
    scored = score(board_set / "d2" / "test" / result.board_id, saved, pool=kicad_pool)
    assert scored["status"] == "ok", scored["reason"]
    assert math.isclose(scored["pot"], result.total_reward, rel_tol=0, abs_tol=1e-9)
    assert scored["unconnected"] == 0


def test_text_format_and_determinism(make_env):
    _, wrapper, model, result = _episode(make_env)
    system = model.seen[0][0]
    assert system["role"] == "system" and "(board \"board_00001\"" in system["content"]
    for messages in model.seen:
        assert messages[0] == system  # the static part once, in the system message
        assert [m["role"] for m in messages[1:]] == ["user", "assistant"] * \
            ((len(messages) - 2) // 2) + ["user"]
        for message in messages[1:]:
            assert message["content"].isascii()
            assert "(board " not in message["content"] and "(pads" not in message["content"]
    numbers = [SEXPR_NUMBER.findall(_sexpr_parts(m[-1]["content"])) for m in model.seen]
    numbers.append(SEXPR_NUMBER.findall(_sexpr_parts(system["content"])))
    flat = [n for group in numbers for n in group]
    assert flat and all(re.fullmatch(r"-?\d+\.\d{3}", n) for n in flat)
    assert all("-0.000" not in m["content"] for messages in model.seen for m in messages)
    # a second run of the same episode gives the same text, message for message
    _, _, again, result_again = _episode(make_env)
    assert again.seen == model.seen
    assert [r.outcome for r in result_again.records] == [r.outcome for r in result.records]
    assert result_again.total_reward == result.total_reward


def test_wrapper_spaces_and_early_stop(make_env):
    env = make_env("d2", max_steps=30)
    wrapper = LLMWrapper(env, turns=0)
    text, info = wrapper.reset(seed=0, options={"index": 0})
    assert wrapper.observation_space.contains(text)
    assert set(info["llm"]) >= {"system", "tools"} and info["llm"]["tools"] == wrapper.tools
    assert wrapper.action_space.contains("net_end()")
    text, reward, terminated, truncated, info = wrapper.step("net_end()")
    assert wrapper.observation_space.contains(text)
    assert info["llm"]["outcome"] == "rejected: net_end is masked in phase no_net"
    assert [m["role"] for m in wrapper.messages()] == ["system", "user"]  # turns=0: none kept
    stopped = run_episode(wrapper, lambda messages, tools: STOP, seed=0, options={"index": 0})
    assert stopped.stopped and stopped.steps == 0 and not stopped.terminated
    assert stopped.truncated and stopped.total_reward == 0.0  # finish_episode: nothing drawn
    capped = run_episode(env, lambda messages, tools: "net_end()", max_replies=3, seed=0)
    assert capped.steps == 3 and not capped.stopped and capped.truncated
    assert all(r.outcome.startswith("rejected") for r in capped.records)


def test_wrapper_passes_gymnasiums_check(make_env):
    from gymnasium.utils.env_checker import check_env

    with pytest.warns(UserWarning, match="different from the unwrapped"):
        check_env(LLMWrapper(make_env("d2", max_steps=20)), skip_render_check=True)


def test_mm_has_three_decimals():
    from pcbdata.env.llm.text import mm

    assert [mm(v) for v in (0, -0.0, -0.0001, 1.2345678, 109.0685, -3.5)] == [
        "0.000", "0.000", "0.000", "1.235", "109.069", "-3.500"]

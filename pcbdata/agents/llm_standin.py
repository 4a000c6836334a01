"""A scripted stand-in for a language model (tests, examples without an API key): the shipped
`ScriptedAgent` decides from the wrapper's raw observation, and its action is sent back as a
model would send it, as text (`make_line(3, walkaround)`) or as a tool call. It reads
`LLMWrapper.last_obs` / `last_info`, which a real model never sees."""
from __future__ import annotations

import json

from pcbdata.agents.scripted import ScriptedAgent
from pcbdata.env.llm.tools import action_call, call_text
from pcbdata.env.llm.wrapper import STOP, LLMWrapper

STYLES = ("text", "tool_calls", "bare", "alternate")


def as_reply(action: dict, net_names, style: str, index: int = 0):
    """An environment action as a model's reply in `style` (`alternate`: text, tool_calls,
    bare in turn by `index`)."""
    if style == "alternate":
        style = STYLES[index % 3]
    verb, arguments = action_call(action, net_names)
    if style == "text":
        return call_text(verb, arguments)
    call = {"name": verb, "arguments": json.dumps(arguments)}
    if style == "bare":
        return {"name": verb, "arguments": arguments}
    return {"role": "assistant", "content": None,
            "tool_calls": [{"id": f"call_{index}", "type": "function", "function": call}]}


class ScriptedModel:
    """`reply = model(messages, tools)` backed by `ScriptedAgent`; `STOP` when it is done."""

    def __init__(self, wrapper: LLMWrapper, style: str = "alternate", seed: int = 0):
        if style not in STYLES:
            raise ValueError(f"style {style!r}: one of {', '.join(STYLES)}")
        self.wrapper, self.style = wrapper, style
        self.agent = ScriptedAgent(seed=seed)
        self.calls = 0

    def __call__(self, messages: list[dict], tools: list[dict]):
        obs, info = self.wrapper.last_obs, self.wrapper.last_info
        assert obs is not None and info is not None, "the wrapper has not been reset"
        action = self.agent.act(obs, info)
        if self.agent.done:
            return STOP
        self.calls += 1
        return as_reply(action, self.wrapper.net_names, self.style, self.calls)


class PaperScriptedModel:
    """The scripted baseline speaking the paper's protocol (`pcbdata.env.llm.paper`): `reply =
    model()` for the session's current step, `<think>...</think><action>BODY</action>` with
    the action's point in mm (three decimals); None when the agent is done. `bad` maps a
    step number to a reply sent instead (a malformed or refused one: tests, the replay
    recordings); the agent is not asked at those steps."""

    def __init__(self, session, seed: int = 0, bad: dict[int, str] | None = None):
        self.session, self.bad = session, dict(bad or {})
        self.agent = ScriptedAgent(seed=seed)

    def __call__(self) -> str | None:
        from pcbdata.env.llm.paper import action_body

        step = self.session.turn + 1
        if step in self.bad:
            return self.bad[step]
        action = self.agent.act(self.session.obs, self.session.info)
        if self.agent.done:
            return None
        body = action_body(action, self.session.ids, self.session.obs)
        return f"<think>scripted step {step}</think><action>{body}</action>"

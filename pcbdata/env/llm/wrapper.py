"""Tool-using language models on the routing environment.

`LLMWrapper(env)`: a Gymnasium wrapper whose observation is the step's message text and whose
action is the model's reply (text, or a tool-call structure: `pcbdata.env.llm.tools`). It
keeps the conversation: `messages()` is the system message (rules and the board's static part,
once) followed by the last `turns` exchanges and the current user message (the dynamic part,
the allowed verbs, the last `history` actions marked ok / rejected / no effect, the streak
line). `run_episode(env, model)` calls `reply = model(messages, tools)` until the episode
ends and returns an `EpisodeResult`.
"""
from __future__ import annotations

import json
import string
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import RecordConstructorArgs

from pcbdata.env.llm import text as llm_text
from pcbdata.env.llm.tools import DEFAULTS, PARAMETERS, Parsed, parse_reply, tool_schema
from pcbdata.env.types import ACTION_TYPES, MODES

#: A model returns this to end the episode early, as a scripted agent does when it has nothing
#: left to try: `run_episode` then calls `finish_episode()` (the final DRC's correction is the
#: last reward; the episode is truncated).
STOP = "<stop>"
#: Characters of the text spaces (ASCII: net names are written with \\u escapes).
CHARSET = string.printable

RULES = """\
You route a printed circuit board. Board coordinates are in mm, x to the right, y down.
Goal: join every open connection (the ratsnest; `unconnected` counts them) with short tracks,
few vias and no DRC violation.
Work net by net: net_select a net with open connections, start_route on one of its candidate
points (a pad), then make_line / make_via to candidate points or finish (routes to the nearest
pad of the net not yet joined to the head's copper), and net_end when the net is done.
Candidate points are listed per step with an index, a kind and what they are allowed for;
indices change from step to step, so use the current list. Modes (each step lists those
available): walkaround routes around other nets' copper (it may find no path: nothing
changes), mark_obstacles lays the line straight and lets DRC mark the violations,
push_n_shove moves other nets' tracks out of the way when walkaround finds no path.
Reply with exactly one tool call, or one line of text such as make_line(3, walkaround) or
net_select("NET1"). Anything else is refused (the step still counts) and the next message
says why. The board's static part follows; each step's message gives the changing part."""


@dataclass(frozen=True)
class StepRecord:
    """One reply and what came of it."""

    step: int
    reply: Any  # as the model sent it
    call: str  # canonical call text, "" when the reply could not be read
    action: dict  # what the environment was given (idle for a refused reply)
    reason: str | None  # why it was refused: the parser's or the environment's reason
    outcome: str  # "ok", "rejected: ...", "no effect: ..."
    reward: float


@dataclass
class EpisodeResult:
    board_id: str
    total_reward: float
    steps: int
    terminated: bool
    truncated: bool
    stopped: bool  # the model sent STOP
    unconnected: int
    drv: int
    records: list[StepRecord] = field(default_factory=list)


def _state_key(obs: dict) -> bytes:
    """What a step can change: copper and the router head (not the step counter)."""
    geo, head = obs["routing_geometry"], obs["router_head"]
    parts = [geo["tracks"], geo["vias"], head["phase"], head["net"], head["position"],
             head["layer"]]
    return b"".join(np.ascontiguousarray(p).tobytes() for p in parts)


def outcome_of(parsed: Parsed, info: dict, changed: bool) -> str:
    """The history mark of a step: rejected (parser or masks), no effect (router failed,
    nothing changed) or ok."""
    if parsed.reason:
        return f"rejected: {parsed.reason}"
    if info.get("rejected"):
        return f"rejected: {info['rejected']}"
    router = info.get("router")
    if router and not router.get("ok", True):
        return f"no effect: router failed ({router.get('reason')})"
    if info.get("engine_failure"):
        return f"no effect: engine failure ({info['engine_failure']})"
    return "ok" if changed else "no effect: nothing changed"


def ascii_only(text: str) -> str:
    """Non-ASCII characters as backslash escapes (the messages stay ASCII)."""
    return text.encode("ascii", "backslashreplace").decode("ascii")


def reply_text(reply, parsed: Parsed, limit: int = 200) -> str:
    """The reply as the assistant message's content: the canonical call when it was read,
    else the reply itself (JSON for structures), clipped."""
    if parsed.call:
        return parsed.call
    text = reply if isinstance(reply, str) else json.dumps(reply, sort_keys=True, default=str)
    text = ascii_only(text)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def allowed_text(mask: dict) -> str:
    """The verbs the masks allow this step, with their arguments, and the available modes."""
    verbs = []
    for index, name in enumerate(ACTION_TYPES):
        if name in PARAMETERS and mask["type"][index]:
            shown = [f"{p}={DEFAULTS[p]}" if p in DEFAULTS else p for p in PARAMETERS[name]]
            verbs.append(f"{name}({', '.join(shown)})")
    modes = [m for i, m in enumerate(MODES) if mask["mode"][i]]
    return f"Allowed now: {', '.join(verbs) or 'nothing'}. Modes: {', '.join(modes)}."


class LLMWrapper(gym.Wrapper, RecordConstructorArgs):
    """Text observation (the step's user message), text or tool-call action (the reply).

    `history`: actions listed in each message; `turns`: exchanges kept in `messages()`;
    `streak_from`: consecutive rejected replies from which the streak line is shown.
    `info["llm"]` holds the call read, the reason of a refusal and the outcome; at reset also
    the system message and the tools."""

    def __init__(self, env: gym.Env, history: int = 8, turns: int = 4, streak_from: int = 2):
        RecordConstructorArgs.__init__(self, history=history, turns=turns,
                                       streak_from=streak_from)  # check_env can remake it
        gym.Wrapper.__init__(self, env)
        self.history_size, self.turns, self.streak_from = history, turns, streak_from
        self.observation_space = spaces.Text(max_length=1 << 24, charset=CHARSET)
        self.action_space = spaces.Text(max_length=4096, charset=CHARSET)
        self.max_candidates = int(env.action_space["candidate"].n)  # type: ignore[index]
        self.tools = tool_schema(self.max_candidates)
        self.system_message = ""
        self.net_names: list[str] = []
        self.records: list[StepRecord] = []
        self.last_obs: dict | None = None  # the raw observation and info (for stand-ins)
        self.last_info: dict | None = None

    # ---- episode ---------------------------------------------------------------------------
    def reset(self, *, seed=None, options=None):
        obs, info = self.env.reset(seed=seed, options=options)
        self._names = llm_text.Names(info["net_names"], info["layers"])
        self.net_names = list(info["net_names"])
        self.system_message = RULES + "\n\n" + llm_text.static_text(obs, info)
        self._history: deque[str] = deque(maxlen=self.history_size)
        self._exchanges: deque[tuple[str, str]] = deque(maxlen=max(self.turns, 0))
        self._streak, self._last_problem = 0, None
        self.records = []
        text = self._remember(obs, info)
        info = dict(info, llm={"system": self.system_message, "tools": self.tools,
                               "call": "", "reason": None, "outcome": None})
        return text, info

    def step(self, reply):
        assert self.last_obs is not None and self.last_info is not None, "call reset() first"
        parsed = parse_reply(reply, self._names.nets, self.max_candidates)
        before, user = _state_key(self.last_obs), self._user
        obs, reward, terminated, truncated, info = self.env.step(parsed.action)
        outcome = outcome_of(parsed, info, _state_key(obs) != before)
        reason = parsed.reason or info.get("rejected")
        step = len(self.records) + 1
        self.records.append(StepRecord(step, reply, parsed.call, parsed.action, reason, outcome,
                                       float(reward)))
        self._note(step, reply, parsed, outcome, float(reward))
        self._exchanges.append((user, reply_text(reply, parsed)))
        text = self._remember(obs, info)
        info = dict(info, llm={"call": parsed.call, "reason": reason, "outcome": outcome})
        return text, reward, terminated, truncated, info

    def finish_episode(self):
        """Ends the episode early (`RoutingEnv.finish_episode`); the text observation of its
        last transition. Not a reply: nothing is added to `records` or the history."""
        ended = self.env.unwrapped.finish_episode()  # type: ignore[attr-defined]
        obs, reward, terminated, truncated, info = ended
        text = self._remember(obs, info)
        return text, reward, terminated, truncated, dict(info, llm={"call": "", "reason": None,
                                                                    "outcome": "finished"})

    def _note(self, step: int, reply, parsed: Parsed, outcome: str, reward: float) -> None:
        shown = parsed.call or f"<bad reply: {reply_text(reply, parsed, 60)}>"
        gain = f" (reward {reward:+.3f})" if outcome == "ok" and reward else ""
        outcome = ascii_only(outcome)  # an environment reason may name a non-ASCII net
        self._history.append(f"step {step}: {shown} -> {outcome}{gain}")
        rejected = outcome.startswith("rejected")
        self._streak = self._streak + 1 if rejected else 0
        self._last_problem = outcome if outcome != "ok" else None

    def _remember(self, obs: dict, info: dict) -> str:
        self.last_obs, self.last_info = obs, info
        self._user = self.user_message(obs, info)
        return self._user

    # ---- messages --------------------------------------------------------------------------
    def user_message(self, obs: dict, info: dict) -> str:
        lines = [llm_text.dynamic_text(obs, info, self._names), allowed_text(info["action_mask"])]
        if self._history:
            lines.append("Last actions (oldest first):")
            lines += [f"  {entry}" for entry in self._history]
        if self._last_problem:
            lines.append(f"Your last reply: {self._last_problem}")
        if self._streak >= self.streak_from:
            lines.append(f"{self._streak} rejected replies in a row: send exactly one call to "
                         f"an allowed verb.")
        lines.append("Reply with exactly one call.")
        return "\n".join(lines)

    def messages(self) -> list[dict]:
        """system, then the last `turns` (user, assistant) exchanges, then the current user
        message: at most 2 * turns + 2 messages, whatever the episode's length."""
        out = [{"role": "system", "content": self.system_message}]
        for user, assistant in self._exchanges:
            out += [{"role": "user", "content": user}, {"role": "assistant", "content": assistant}]
        out.append({"role": "user", "content": self._user})
        return out


def run_episode(env: gym.Env, model, *, seed: int | None = None, options: dict | None = None,
                max_replies: int | None = None, **wrapper_options) -> EpisodeResult:
    """An episode driven by `reply = model(messages, tools)`, from reset until it terminates,
    is truncated, the model returns `STOP` or `max_replies` replies were used (in those two
    cases the episode is ended with `finish_episode()`, whose reward is in `total_reward`).
    `env` is a routing environment or an `LLMWrapper` around one; `wrapper_options` go to the
    wrapper."""
    wrapper = env if isinstance(env, LLMWrapper) else LLMWrapper(env, **wrapper_options)
    _, info = wrapper.reset(seed=seed, options=options)
    total, terminated, truncated, stopped = 0.0, False, False, False
    while not (terminated or truncated):
        out = max_replies is not None and len(wrapper.records) >= max_replies
        reply = STOP if out else model(wrapper.messages(), wrapper.tools)
        stopped = not out and isinstance(reply, str) and reply == STOP
        if out or stopped:  # the final DRC ends the episode
            _, reward, terminated, truncated, info = wrapper.finish_episode()
        else:
            _, reward, terminated, truncated, info = wrapper.step(reply)
        total += float(reward)
    return EpisodeResult(board_id=info["board_id"], total_reward=total,
                         steps=len(wrapper.records), terminated=terminated, truncated=truncated,
                         stopped=stopped, unconnected=int(info["unconnected"]),
                         drv=int(info["drv"]), records=list(wrapper.records))

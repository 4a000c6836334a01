"""Language-model agents over an OpenAI-compatible chat-completions server
(`pcbdata.agents.llm_client`), run by `pcbdata rollout --agent llm | llm-plan | llm-direct`.

- `LLMAgent` (`llm`, closed loop): one request per step through `LLMWrapper` (the board as
  text, the six tools, the strict parser); the reply's tool call or text call is the step.
  The text `<stop>` (no tool call) ends the episode early, as a scripted agent that is done.
- `PlanAgent` (`llm-plan`, open loop): one request; the model sends the whole sequence of
  actions (tool calls, a JSON list of `{"name", "arguments"}` or one text call per line),
  carried out in order with no feedback.
- `DirectAgent` (`llm-direct`, open loop): one request; the model writes the routing as
  `(segment ...)`, `(arc ...)` and `(via ...)` items of .kicad_pcb syntax, added to the
  instance's board text as they are; the evaluator scores what comes of it.

A fault of the server (`ServerFault`) ends the episode with its reason; a reply the parser
cannot read is a step that does nothing (a parse failure), and `MAX_UNREADABLE` of them in a
row end the episode. Each rollout's JSON holds `llm`: the prompt/format version, the options
(never the key), the accounting, the faults and why the episode ended.
"""
from __future__ import annotations

import json
import re
import time
from pathlib import Path

from pcbdata.agents.llm_client import ChatClient, ServerFault, client_options
from pcbdata.core.tree import BOARD_FILE, board_dir
from pcbdata.env.llm.wrapper import RULES, LLMWrapper

#: Version of what the model is shown and what it may answer (system prompts here, the
#: wrapper's text and tools): bump it when either changes; recorded in every rollout.
PROMPT_VERSION = "pcbdata-llm-1"
STOP_WORDS = ("<stop>", "stop")
ONE_CALL = "Reply with exactly one call."  # the closed loop's last line of a user message
#: Unreadable replies in a row that end a closed-loop episode.
MAX_UNREADABLE = 10
MAX_FAULTS_KEPT = 50  # fault entries kept in a rollout's JSON (the count is always kept)
STOP_RULE = ("When nothing is left that you can route, reply with the text <stop> and no tool "
             "call: the episode then ends.")
PLAN_RULES = RULES.split("\nReply with exactly one tool call")[0] + """
This is open loop: send the WHOLE sequence of actions now, in order, as tool calls (one per
action), or as a JSON list of {"name": ..., "arguments": {...}}, or one call per line. They are
carried out one after the other with no feedback. The candidate list below is the first step's;
each later step lists its candidates the same way, from the state the plan has reached."""
DIRECT_RULES = """\
You route a printed circuit board. Board coordinates are in mm, x to the right, y down.
Goal: join every open connection (each net's pads) with copper, with no DRC violation.
Write the routing as KiCad 9 .kicad_pcb items, one per line and nothing else:
  (segment (start X Y) (end X Y) (width W) (layer "F.Cu") (net CODE))
  (arc (start X Y) (mid X Y) (end X Y) (width W) (layer "B.Cu") (net CODE))
  (via (at X Y) (size S) (drill D) (layers "F.Cu" "B.Cu") (net CODE))
CODE is the net's code in the (net CODE "name") table below. The items are added to the
board file as written; anything else in the reply is ignored."""


class _LLMBase:
    """Client, accounting and the `llm` record shared by the three agents."""

    kind = ""
    max_tokens: int | None = None
    prompt_version = PROMPT_VERSION

    def __init__(self, seed: int = 0, **options):
        self.seed = seed
        self.options = client_options(options)
        if self.options["max_tokens"] is None and self.max_tokens:
            self.options["max_tokens"] = self.max_tokens
        self.client = ChatClient(self.options)
        self.faults: list[dict] = []
        self.fault_count = 0
        self.end: str | None = None
        self.board_text: str | None = None  # the rollout's board when the agent writes it

    def preflight(self) -> str | None:
        """The server's start-up check (`ChatClient.preflight`): a warning, or None."""
        return self.client.preflight()

    def act(self, obs, info):
        raise TypeError(f"{type(self).__name__} runs whole episodes (episode()), not act()")

    def _fault(self, step: int, kind: str, reason: str) -> None:
        self.fault_count += 1
        if len(self.faults) < MAX_FAULTS_KEPT:
            self.faults.append({"step": step, "kind": kind, "reason": reason})

    def _ask(self, step: int, messages: list[dict], tools: list[dict] | None,
             extra: dict | None = None) -> dict | None:
        """The assistant message, or None after a fault (recorded, it ends the episode);
        `extra`: fields added to the request body (`ChatClient.chat`)."""
        try:
            return self.client.chat(messages, tools, self.seed, **(extra or {}))
        except ServerFault as fault:
            self._fault(step, fault.kind, fault.reason)
            self.end = f"server fault: {fault.reason}"
            return None

    def identity(self) -> dict:
        """The model, its server and the sampling settings (the seed is the offset each
        rollout's number is added to), for the rollout's `agent_identity`."""
        options = self.options
        return {"model": options["model"], "base_url": options["base_url"],
                "sampling": {"temperature": options["temperature"],
                             "seed": int(options["seed"] or 0),
                             "max_tokens": options["max_tokens"]},
                "prompt_version": self.prompt_version}

    def llm_record(self) -> dict:
        shown = {k: v for k, v in self.options.items() if k != "api_key_env"}
        return {"agent": self.kind, "prompt_version": self.prompt_version,
                "options": dict(shown, sampling=self.client.sampling(self.seed)),
                "accounting": self.client.accounting.numbers(),
                "latency_s": self.client.accounting.latency_s,
                "faults": self.faults, "fault_count": self.fault_count, "end": self.end}

    def _record(self, board_id: str, began: float, total, steps: int, ended: tuple,
                info: dict | None) -> dict:
        terminated, truncated = ended
        return {"board_id": board_id, "rollout": self.seed,
                "time_s": time.perf_counter() - began, "steps": steps, "reward": total,
                "terminated": terminated, "truncated": truncated,
                "unconnected": None if info is None else info["unconnected"],
                "drv": None if info is None else info["drv"],
                "engine_failure": None if info is None else info.get("engine_failure"),
                "llm": self.llm_record()}


def is_stop(message: dict) -> bool:
    content = message.get("content")
    return (not message.get("tool_calls") and isinstance(content, str)
            and content.strip().strip("`").strip().lower() in STOP_WORDS)


class LLMAgent(_LLMBase):
    """Closed loop: one request per step (`--agent llm`)."""

    kind = "llm"
    max_tokens = 512

    def episode(self, env, board_id: str, seed: int, env_kwargs: dict) -> dict:
        began = time.perf_counter()
        wrapper = LLMWrapper(env)
        _, info = wrapper.reset(seed=seed, options={"board_id": board_id})
        total, ended, unreadable = 0.0, (False, False), 0
        while not any(ended):
            step = len(wrapper.records) + 1
            if unreadable >= MAX_UNREADABLE:
                message, self.end = None, f"{unreadable} unreadable replies in a row"
            else:
                message = self._ask(step, self._messages(wrapper), wrapper.tools)
            if message is None or is_stop(message):
                if message is not None:
                    self.end = "stopped by the model"
                _, reward, *flags, info = wrapper.finish_episode()
                total, ended = total + float(reward), (flags[0], flags[1])
                break
            _, reward, *flags, info = wrapper.step(message)
            total, ended = total + float(reward), (flags[0], flags[1])
            unreadable = self._note_reply(wrapper, step, unreadable)
        if self.end is None:
            self.end = "terminated" if ended[0] else "truncated"
        return self._record(board_id, began, total, len(wrapper.records), ended, info)

    def _messages(self, wrapper: LLMWrapper) -> list[dict]:
        messages = wrapper.messages()
        messages[0] = dict(messages[0], content=messages[0]["content"] + "\n" + STOP_RULE)
        return messages

    def _note_reply(self, wrapper: LLMWrapper, step: int, unreadable: int) -> int:
        record = wrapper.records[-1]
        if record.call:
            return 0
        self.client.accounting.parse_failures += 1
        self._fault(step, "unreadable", record.reason or "unreadable reply")
        return unreadable + 1


class PlanAgent(_LLMBase):
    """Open loop, actions: one request, the whole action sequence (`--agent llm-plan`)."""

    kind = "llm-plan"
    max_tokens = 8192

    def episode(self, env, board_id: str, seed: int, env_kwargs: dict) -> dict:
        began = time.perf_counter()
        wrapper = LLMWrapper(env)
        first, info = wrapper.reset(seed=seed, options={"board_id": board_id})
        static = wrapper.system_message[len(RULES):]
        messages = [{"role": "system", "content": PLAN_RULES + static},
                    {"role": "user", "content": first.removesuffix(ONE_CALL)
                     + "Send the whole plan now."}]
        message = self._ask(1, messages, wrapper.tools)
        calls = [] if message is None else plan_calls(message)
        total, ended = 0.0, (False, False)
        for call in calls:
            if any(ended):
                break
            _, reward, *flags, info = wrapper.step(call)
            total, ended = total + float(reward), (flags[0], flags[1])
            if not wrapper.records[-1].call:
                self.client.accounting.parse_failures += 1
                self._fault(len(wrapper.records), "unreadable", wrapper.records[-1].reason or "")
        if not any(ended):
            _, reward, *flags, info = wrapper.finish_episode()
            total, ended = total + float(reward), (flags[0], flags[1])
        if self.end is None:
            self.end = f"plan of {len(calls)} actions carried out" if calls else "empty plan"
        return self._record(board_id, began, total, len(wrapper.records), ended, info)


def plan_calls(message: dict) -> list:
    """The actions of a plan reply, each as the wrapper's parser takes one reply."""
    calls = message.get("tool_calls")
    if isinstance(calls, list) and calls:
        return [c.get("function", c) if isinstance(c, dict) else c for c in calls]
    content = message.get("content")
    if not isinstance(content, str):
        return []
    text = _unfenced(content)
    try:
        items = json.loads(text)
    except ValueError:
        return [line.strip() for line in text.splitlines() if line.strip()]
    return items if isinstance(items, list) else [items]


def _unfenced(text: str) -> str:
    """The text without a Markdown code fence around it."""
    match = re.search(r"```[A-Za-z]*\n(.*?)```", text, re.DOTALL)
    return (match.group(1) if match else text).strip()


class DirectAgent(_LLMBase):
    """Open loop, copper: one request, the routing as .kicad_pcb items (`--agent llm-direct`)."""

    kind = "llm-direct"
    max_tokens = 16384

    def episode(self, env, board_id: str, seed: int, env_kwargs: dict) -> dict:
        began = time.perf_counter()
        wrapper = LLMWrapper(env)
        wrapper.reset(seed=seed, options={"board_id": board_id})
        path = board_dir(env_kwargs["root"], env_kwargs["config"], env_kwargs["split"],
                         board_id) / BOARD_FILE
        board = Path(path).read_text(encoding="utf-8")
        static = wrapper.system_message[len(RULES):]
        messages = [{"role": "system", "content": DIRECT_RULES},
                    {"role": "user", "content": static.strip() + "\n" + net_table(board)
                     + "\nWrite the routing now."}]
        message = self._ask(1, messages, None)
        content = "" if message is None else message.get("content")
        items = copper_items(content if isinstance(content, str) else "")
        if message is not None and not items:
            self.client.accounting.parse_failures += 1
            self._fault(1, "unreadable", "no (segment ...), (arc ...) or (via ...) item")
        self.board_text = with_items(board, items)
        if self.end is None:
            self.end = f"{len(items)} copper items written"
        record = self._record(board_id, began, None, 0, (False, False), None)
        record["llm"]["items"] = len(items)
        return record


def net_table(board: str) -> str:
    """The board file's net table, `(net CODE "name")` per line (pads repeat them)."""
    found = re.findall(r'^\s*(\(net \d+ "(?:[^"\\]|\\.)*"\))\s*$', board, re.MULTILINE)
    return "(net_codes\n" + "\n".join(f"  {n}" for n in dict.fromkeys(found)) + ")"


_ITEM_START = re.compile(r"\((segment|arc|via)[\s)]")


def copper_items(text: str) -> list[str]:
    """Every balanced `(segment ...)`, `(arc ...)` and `(via ...)` in `text` (strings may
    hold parentheses); whatever is around or between them is dropped."""
    items: list[str] = []
    position = 0
    while True:
        match = _ITEM_START.search(text, position)
        if not match:
            return items
        end = _balanced_end(text, match.start())
        if end is None:
            return items
        items.append(" ".join(text[match.start():end].split()))
        position = end


def _balanced_end(text: str, start: int) -> int | None:
    depth, quoted, escaped = 0, False, False
    for index in range(start, len(text)):
        char = text[index]
        if quoted:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == '"':
                quoted = False
            continue
        if char == '"':
            quoted = True
        elif char == "(":
            depth += 1
        elif char == ")":
            depth -= 1
            if depth == 0:
                return index + 1
    return None


def with_items(board: str, items: list[str]) -> str:
    """The board text with `items` added before its closing parenthesis."""
    cut = board.rstrip().rfind(")")
    if cut < 0 or not items:
        return board
    return board[:cut] + "".join(f"\t{item}\n" for item in items) + board[cut:]

"""The paper's language-model agents (SPEC 7.2) over an OpenAI-compatible chat-completions
server: `llm-paper` (interactive, one request per step), `llm-paper-plan` (one request: an
`<actions>` list replayed without feedback) and `llm-paper-direct` (one request: `(segment
...)` and `(via ...)` items inserted into the board file). The protocol is
`pcbdata.env.llm.paper` (board text, parser, history and tags) with the prompts of
`pcbdata.env.llm.paper_prompts`; the client, faults and the `llm` record are those of
`pcbdata.agents.llm_agents`.

Beside the client's options each agent takes the protocol options of `PAPER_DEFAULTS`
(`pcbdata rollout --llm-option NAME=VALUE`). Each rollout's JSON holds `llm.accounting` with
the paper's token split (`system_tokens`, `user_tokens`, `response_tokens`, summed over the
protocol's requests, and `tokens_measured_by`) and `agent_report` with every way a reply
became `idle`.
"""
from __future__ import annotations

import re
import time
from collections import deque
from pathlib import Path

from pcbdata.agents.llm_agents import _balanced_end, _LLMBase, net_table, with_items
from pcbdata.core.errors import UserError
from pcbdata.core.sexpr_text import cut_problem
from pcbdata.core.tree import BOARD_FILE, board_dir
from pcbdata.env.llm.paper import IDLE_KINDS, PaperSession, plan_board
from pcbdata.env.llm.paper_prompts import DIRECT, PAPER_PROMPT_VERSION, PLAN, SYSTEM
from pcbdata.env.llm.text import mm

#: The protocol options and their defaults. `turns`: T, model calls per episode (each one
#: environment step); `history`: accepted turns shown; `no_effect`: what the [no effect] tag
#: judges (routing verbs, or all); `require_think`: a reply needs its <think>;
#: `chat_history`: earlier turns also sent as chat messages (the paper does not say; off: a
#: fresh system + user pair per turn); `system_tokens`: how the system message is measured
#: (auto: the tokenize route, else a request that sends it alone; tokenize; request; off);
#: `plan_failure`: what a failed plan line does (skip_net: the net's remaining lines are
#: skipped, but a net_end still releases it; continue); `plan_max_steps`: a cap on replayed lines
#: (None: the environment's step limit); `board_first`: board_static before the prompt in
#: the system message (the paper does not say where it sits; default after);
#: `direct_repair`: fill a missing width of an engine-free segment, size, drill or layers of
#: a via from its net's rules (the paper does not say; default: items as written);
#: `extra_body`: fields added to every request's body
#: (a null removes one the client sends: OpenAI's reasoning models take
#: `{"max_completion_tokens": 256, "max_tokens": null, "temperature": null}`; vLLM's Qwen3
#: `{"chat_template_kwargs": {"enable_thinking": false}}`).
PAPER_DEFAULTS: dict = {"turns": 200, "history": 2, "no_effect": "routing",
                        "require_think": True, "chat_history": False, "system_tokens": "auto",
                        "plan_failure": "skip_net", "plan_max_steps": None,
                        "board_first": False, "direct_repair": False, "extra_body": {}}
_CHOICES = {"no_effect": ("routing", "all"), "system_tokens": ("auto", "tokenize", "request",
                                                              "off"),
            "plan_failure": ("skip_net", "continue")}


def paper_options(options: dict) -> tuple[dict, dict]:
    """(protocol options with defaults, the client's options)."""
    protocol = {k: options[k] for k in PAPER_DEFAULTS if k in options}
    client = {k: v for k, v in options.items() if k not in PAPER_DEFAULTS}
    merged = {**PAPER_DEFAULTS, **protocol}
    for name, allowed in _CHOICES.items():
        if merged[name] not in allowed:
            raise UserError(f"--llm-option {name}={merged[name]!r}: one of {', '.join(allowed)}")
    for name in ("turns", "history"):
        if not isinstance(merged[name], int) or isinstance(merged[name], bool) \
                or merged[name] < (1 if name == "turns" else 0):
            raise UserError(f"--llm-option {name}={merged[name]!r}: a whole number "
                            f"(turns >= 1, history >= 0)")
    for name in ("require_think", "chat_history", "board_first", "direct_repair"):
        if not isinstance(merged[name], bool):
            raise UserError(f"--llm-option {name}={merged[name]!r}: true or false")
    if not isinstance(merged["extra_body"], dict) or {"model", "messages"} & \
            set(merged["extra_body"]):
        raise UserError(f"--llm-option extra_body={merged['extra_body']!r}: a JSON object "
                        f"without model or messages")
    cap = merged["plan_max_steps"]
    if cap is not None and (not isinstance(cap, int) or isinstance(cap, bool) or cap < 1):
        raise UserError(f"--llm-option plan_max_steps={cap!r}: a whole number >= 1")
    return merged, client


class _PaperBase(_LLMBase):
    """Protocol options, the paper's token split, the idle counts."""

    prompt_version = PAPER_PROMPT_VERSION

    def __init__(self, seed: int = 0, **options):
        self.paper, client = paper_options(options)
        super().__init__(seed, **client)
        self.system_per_request: int | None = None
        self.measured_by = "not measured"
        self.prompt_sum = self.response_sum = self.with_usage = 0
        self.cut_by_max_tokens = 0
        self.first_call: float | None = None

    def llm_record(self) -> dict:
        record = super().llm_record()
        record["options"]["protocol"] = dict(self.paper)
        record["accounting"].update(self._token_split())
        if self.first_call is not None:
            record["time_from_first_call_s"] = round(time.perf_counter() - self.first_call, 6)
        return record

    def _token_split(self) -> dict:
        """System / User / Response as the paper splits them, over the protocol's requests
        with usage (the measuring request is not one of them)."""
        per = self.system_per_request
        system = None if per is None else per * self.with_usage
        user = None if system is None else max(self.prompt_sum - system, 0)
        total = None if system is None or user is None else system + user + self.response_sum
        return {"system_tokens": system, "system_tokens_per_request": per,
                "user_tokens": user, "response_tokens": self.response_sum,
                "total_tokens": total, "tokens_measured_by": self.measured_by,
                "requests_with_usage": self.with_usage}

    def _measure(self, system: str) -> None:
        """The system message's tokens, once per episode (`system_tokens` option)."""
        how = self.paper["system_tokens"]
        messages = [{"role": "system", "content": system}]
        if how == "off":
            self.measured_by = "not measured (system_tokens=off)"
            return
        if how in ("auto", "tokenize"):
            count, said = self.client.tokenize(messages)
            if count is not None:
                self.system_per_request, self.measured_by = count, said
                return
            if how == "tokenize":
                self.measured_by = f"not measured: {said}"
                return
        extra = dict(self.paper["extra_body"], max_tokens=1)
        if "max_completion_tokens" in extra:
            extra.update(max_completion_tokens=1, max_tokens=None)
        try:
            self.client.chat(messages, None, self.seed, **extra)
        except Exception as fault:  # noqa: BLE001 - ServerFault: the episode goes on
            self.measured_by = f"not measured: the system-only request failed ({fault})"
            return
        usage = self.client.last_usage
        if usage is None:
            self.measured_by = "not measured: the system-only request's answer had no usage"
            return
        self.system_per_request = usage["prompt_tokens"]
        self.measured_by = "usage of a request that sends the system message alone"

    def _call(self, step: int, messages: list[dict]) -> dict | None:
        """One protocol request (no tools), its usage tallied."""
        if self.first_call is None:
            self.first_call = time.perf_counter()
        message = self._ask(step, messages, None, self.paper["extra_body"])
        if message is not None:
            usage = self.client.last_usage
            if usage is not None:
                self.with_usage += 1
                self.prompt_sum += usage["prompt_tokens"]
                self.response_sum += usage["completion_tokens"]
            self.cut_by_max_tokens += self.client.last_finish_reason == "length"
        return message

    def _report(self, session: PaperSession | None, **extra) -> dict:
        counts = dict(session.counts) if session is not None else {}
        idle = {k: counts.get(k, 0) for k in IDLE_KINDS}
        return {"idle": idle, "idle_total": sum(idle.values()),
                "turns": counts.get("turns", 0), "accepted": counts.get("accepted", 0),
                "no_effect": counts.get("no_effect", 0),
                "cut_by_max_tokens": self.cut_by_max_tokens, **extra}


def _content(message: dict | None):
    return None if message is None else message.get("content")


class PaperAgent(_PaperBase):
    """Interactive (closed loop): one request per step, T = `turns` (`--agent llm-paper`)."""

    kind = "llm-paper"
    max_tokens = 256

    def episode(self, env, board_id: str, seed: int, env_kwargs: dict) -> dict:
        began = time.perf_counter()
        session = PaperSession(env, self.paper["history"], self.paper["no_effect"],
                               self.paper["require_think"])
        static, user, info = session.reset(seed=seed, options={"board_id": board_id})
        system = static + "\n\n" + SYSTEM if self.paper["board_first"] else \
            SYSTEM + "\n" + static
        self._measure(system)
        exchanges: deque[dict] = deque(maxlen=2 * self.paper["history"])
        total, ended = 0.0, (False, False)
        while not any(ended) and session.turn < self.paper["turns"]:
            earlier = list(exchanges) if self.paper["chat_history"] else []
            messages = [{"role": "system", "content": system}, *earlier,
                        {"role": "user", "content": user}]
            message = self._call(session.turn + 1, messages)
            if message is None:
                break
            reward, *flags, info, _ = session.step(_content(message))
            total, ended = total + float(reward), (flags[0], flags[1])
            if not session.outcomes[-1].accepted and session.outcomes[-1].kind != "mask":
                self.client.accounting.parse_failures += 1
            exchanges.extend([{"role": "user", "content": user},
                              {"role": "assistant", "content": str(_content(message) or "")}])
            user = session.user_message()
        if not any(ended):
            if self.end is None:
                self.end = f"turn limit {self.paper['turns']} reached"
            reward, *flags, info = session.finish_episode()
            total, ended = total + float(reward), (flags[0], flags[1])
        if self.end is None:
            self.end = "terminated" if ended[0] else "truncated"
        record = self._record(board_id, began, total, session.turn, ended, info)
        record["agent_report"] = self._report(session, valid_steps=session.valid)
        return record


def plan_lines(content) -> list[str] | None:
    """The lines of the reply's `<actions>...</actions>` (blank lines dropped); None when
    there is no such element."""
    if not isinstance(content, str):
        return None
    found = re.search(r"<actions>(.*?)</actions>", content, re.DOTALL)
    if found is None:
        return None
    return [line.strip() for line in found.group(1).splitlines() if line.strip()]


class PaperPlanAgent(_PaperBase):
    """Plan-and-execute (open loop): one request; its `<actions>` list is replayed in order
    without feedback (`--agent llm-paper-plan`)."""

    kind = "llm-paper-plan"
    max_tokens = 8192  # the paper does not say whether its cap applies to the open loop

    def episode(self, env, board_id: str, seed: int, env_kwargs: dict) -> dict:
        began = time.perf_counter()
        session = PaperSession(env, 0, self.paper["no_effect"], require_think=False)
        _, _, info = session.reset(seed=seed, options={"board_id": board_id})
        board = plan_board(session.obs, info, session.ids)
        self._measure(PLAN)
        message = self._call(1, [{"role": "system", "content": PLAN},
                                 {"role": "user", "content": f"<BOARD>\n{board}\n</BOARD>"}])
        lines = plan_lines(_content(message))
        total, ended, skipped, failing = 0.0, (False, False), 0, False
        cap = self.paper["plan_max_steps"]
        for line in lines or []:
            if any(ended) or (cap is not None and session.turn >= cap):
                skipped += 1
                continue
            if failing and not line.startswith(("net_select", "net_end")):
                skipped += 1
                continue
            reward, *flags, info, outcome = session.step_body(line)
            total, ended = total + float(reward), (flags[0], flags[1])
            if not outcome.accepted and outcome.kind != "mask":
                self.client.accounting.parse_failures += 1
            failing = self.paper["plan_failure"] == "skip_net" and not outcome.accepted
        if not any(ended):
            reward, *flags, info = session.finish_episode()
            total, ended = total + float(reward), (flags[0], flags[1])
        if self.end is None:
            self.end = ("no <actions> element in the reply" if lines is None
                        else f"plan of {len(lines)} lines replayed")
        record = self._record(board_id, began, total, session.turn, ended, info)
        record["agent_report"] = self._report(
            session, plan_lines=None if lines is None else len(lines), skipped_lines=skipped,
            missing_actions=int(message is not None and lines is None))
        return record


_ITEM = re.compile(r"\((segment|via|arc|gr_line|track)[\s)]")


def paper_items(text: str) -> tuple[list[str], int]:
    """The balanced `(segment ...)` and `(via ...)` items of a reply, and how many other
    copper-like items (`arc`, `track`, `gr_line`) it held, which are dropped."""
    items: list[str] = []
    dropped, position = 0, 0
    while True:
        match = _ITEM.search(text, position)
        if not match:
            return items, dropped
        end = _balanced_end(text, match.start())
        if end is None:
            return items, dropped
        if match.group(1) in ("segment", "via"):
            items.append(" ".join(text[match.start():end].split()))
        else:
            dropped += 1
        position = end


def off_octilinear(items: list[str]) -> int:
    """Segments that are not horizontal, vertical or exactly 45 degrees (to 1 nm)."""
    count = 0
    for item in items:
        found = re.search(r"\(start (-?[\d.]+) (-?[\d.]+)\) \(end (-?[\d.]+) (-?[\d.]+)\)", item)
        if not item.startswith("(segment") or found is None:
            continue
        x1, y1, x2, y2 = (round(float(v) * 1e6) for v in found.groups())
        dx, dy = abs(x2 - x1), abs(y2 - y1)
        count += not (dx == 0 or dy == 0 or dx == dy)
    return count


def net_rules(board: str, session: PaperSession) -> dict[str, tuple[str, str, str]]:
    """Net code (as the board file writes it) -> (track width, via diameter, via drill) in mm,
    from the episode's observation."""
    rows = session.obs["board_static"]["nets"]
    out = {}
    for code, name in re.findall(r'^\s*\(net (\d+) "((?:[^"\\]|\\.)*)"\)\s*$', board,
                                 re.MULTILINE):
        index = session.ids.by_name.get(name)
        if index is not None:
            out[code] = (mm(rows[index][3]), mm(rows[index][4]), mm(rows[index][5]))
    return out


def repair_items(items: list[str], rules: dict[str, tuple[str, str, str]]) \
        -> tuple[list[str], int]:
    """Items with a missing `(width ...)` (segments) or `(size ...)`, `(drill ...)`,
    `(layers ...)` (vias) filled from their net's rules; how many changed. An item without a
    known `(net CODE)` is left as written."""
    out, changed = [], 0
    for item in items:
        code = re.search(r"\(net (\d+)\)", item)
        width, size, drill = rules.get(code.group(1), ("", "", "")) if code else ("", "", "")
        added = []
        if width and item.startswith("(segment") and "(width " not in item:
            added.append(f"(width {width})")
        if size and item.startswith("(via"):
            added += [f"({k} {v})" for k, v in (("size", size), ("drill", drill))
                      if f"({k} " not in item]
            if "(layers " not in item:
                added.append('(layers "F.Cu" "B.Cu")')
        if added:
            item = item[:-1].rstrip() + " " + " ".join(added) + ")"
            changed += 1
        out.append(item)
    return out, changed


class PaperDirectAgent(_PaperBase):
    """Engine-free (open loop): one request; the reply's `(segment ...)` and `(via ...)` items
    are inserted into the instance's board file as written (`--agent llm-paper-direct`).
    Whether that file loads is `pcbdata eval`'s parse-fail."""

    kind = "llm-paper-direct"
    max_tokens = 16384  # the paper does not say whether its cap applies to the open loop

    def episode(self, env, board_id: str, seed: int, env_kwargs: dict) -> dict:
        began = time.perf_counter()
        session = PaperSession(env, 0)
        _, _, info = session.reset(seed=seed, options={"board_id": board_id})
        path = board_dir(env_kwargs["root"], env_kwargs["config"], env_kwargs["split"],
                         board_id) / BOARD_FILE
        board = Path(path).read_text(encoding="utf-8")
        text = plan_board(session.obs, info, session.ids) + "\n" + net_table(board)
        self._measure(DIRECT)
        message = self._call(1, [{"role": "system", "content": DIRECT},
                                 {"role": "user", "content": f"<BOARD>\n{text}\n</BOARD>"}])
        content = _content(message)
        items, dropped = paper_items(content if isinstance(content, str) else "")
        if message is not None and not items:
            self.client.accounting.parse_failures += 1
        repaired = 0
        if self.paper["direct_repair"]:
            items, repaired = repair_items(items, net_rules(board, session))
        self.board_text = with_items(board, items)
        problem = cut_problem(self.board_text.encode("utf-8"))
        if self.end is None:
            self.end = f"{len(items)} items inserted"
        record = self._record(board_id, began, None, 0, (False, False), None)
        record["agent_report"] = {
            "items": len(items), "segments": sum(i.startswith("(segment") for i in items),
            "vias": sum(i.startswith("(via") for i in items), "dropped_items": dropped,
            "off_octilinear_segments": off_octilinear(items), "text_problem": problem,
            "repaired_items": repaired,
            "cut_by_max_tokens": self.cut_by_max_tokens}
        return record

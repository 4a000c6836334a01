"""The six routing operations as a tool schema for function-calling language models, and the
strict parser of a model's reply.

A reply is accepted in three shapes: an OpenAI-style assistant message with `tool_calls`
(`{"tool_calls": [{"function": {"name": ..., "arguments": "<json>"}}]}`, any `content`
beside them is commentary), a bare call `{"name": ..., "arguments": {...} or "<json>"}`, or
text holding one call such as `make_line(3, walkaround)` or `net_select("GND")` (an assistant
message without tool calls is read from its `content`). Strict: exactly one call, a known verb,
the right number and types of arguments, ASCII only, a candidate index in range, a known net
name and mode name. Anything else becomes `idle` with a one-line reason (`Parsed.reason`).
Masks are not checked here: an allowed-looking call that the phase machine forbids goes to the
environment, which rejects it with its own reason (`info["rejected"]`).
"""
from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from pcbdata.env.types import (
    ACTION_TYPES,
    FINISH,
    IDLE,
    MAKE_LINE,
    MAKE_VIA,
    MODES,
    NET_END,
    NET_SELECT,
    START_ROUTE,
    WALKAROUND,
)

#: The verbs a model may call, in action-type order (idle is what a bad reply becomes).
VERBS = ("net_select", "net_end", "start_route", "make_line", "make_via", "finish")
#: Each verb's parameters in positional order.
PARAMETERS = {"net_select": ("net",), "net_end": (), "start_route": ("point",),
              "make_line": ("point", "mode"), "make_via": ("point", "mode"),
              "finish": ("mode",)}
#: Parameters that may be left out, with their default.
DEFAULTS = {"mode": MODES[WALKAROUND]}
DESCRIPTIONS = {
    "net_select": "Select the net to route, by its name. Releases any net selected before.",
    "net_end": "Release the selected net (and the route head).",
    "start_route": "Put the route head on a candidate point (a pad, via or track end of the "
                   "selected net), by its index in the candidate list.",
    "make_line": "Route from the head to a candidate point on the head's layer; the head moves "
                 "there.",
    "make_via": "Route to a candidate point like make_line, then drop a through via there; the "
                "head goes to the other outer layer, or to the candidate's layer when that is "
                "another layer (boards with inner layers list the head's point on each).",
    "finish": "Route from the head to the nearest pad of the net on the head's layer that is "
              "not yet joined to the head's copper.",
}
_MAX_SHOWN = 60  # characters of a bad reply quoted in a reason


@dataclass(frozen=True)
class Parsed:
    """A reply read: the environment's action (idle when `reason` is set), the canonical call
    text (`make_line(3, walkaround)`, empty when unreadable) and the reason it was refused."""

    action: dict
    call: str
    reason: str | None


def tool_schema(max_candidates: int) -> list[dict]:
    """One function per operation, as OpenAI-style chat APIs take `tools`."""
    return [{"type": "function",
             "function": {"name": verb, "description": DESCRIPTIONS[verb],
                          "parameters": _parameters(verb, max_candidates)}}
            for verb in VERBS]


def _parameters(verb: str, max_candidates: int) -> dict:
    properties: dict[str, dict] = {}
    for name in PARAMETERS[verb]:
        if name == "net":
            properties[name] = {"type": "string", "description": "the net's name as the board "
                                "lists it"}
        elif name == "point":
            properties[name] = {"type": "integer", "minimum": 0, "maximum": max_candidates - 1,
                                "description": "index of a candidate point of this step"}
        else:
            properties[name] = {"type": "string", "enum": list(MODES), "default": DEFAULTS[name],
                                "description": "routing mode (the step's message lists the "
                                "available ones)"}
    required = [name for name in PARAMETERS[verb] if name not in DEFAULTS]
    return {"type": "object", "properties": properties, "required": required,
            "additionalProperties": False}


# ---- the action <-> call mapping ---------------------------------------------------------
def idle_action() -> dict:
    return {"type": IDLE, "net": 0, "candidate": 0, "mode": WALKAROUND}


def call_text(verb: str, values: Mapping) -> str:
    """The canonical text of a call: `net_select("GND")`, `make_line(3, walkaround)`."""
    shown = [json.dumps(values[n]) if n == "net" else str(values[n]) for n in PARAMETERS[verb]]
    return f"{verb}({', '.join(shown)})"


def action_call(action: Mapping, net_names: Sequence[str]) -> tuple[str, dict]:
    """(verb, arguments) of an environment action (the inverse of `parse_reply`)."""
    verb = ACTION_TYPES[int(action["type"])]
    if verb not in PARAMETERS:
        raise ValueError(f"{verb} is not a verb a model calls")
    values = {"net": net_names[int(action.get("net", 0))],
              "point": int(action.get("candidate", 0)),
              "mode": MODES[int(action.get("mode", WALKAROUND))]}
    return verb, {n: values[n] for n in PARAMETERS[verb]}


def _action(verb: str, values: Mapping, net_names: Sequence[str]) -> dict:
    action = idle_action()
    action["type"] = {"net_select": NET_SELECT, "net_end": NET_END, "start_route": START_ROUTE,
                      "make_line": MAKE_LINE, "make_via": MAKE_VIA, "finish": FINISH}[verb]
    if "net" in values:
        action["net"] = list(net_names).index(values["net"])
    if "point" in values:
        action["candidate"] = values["point"]
    if "mode" in values:
        action["mode"] = MODES.index(values["mode"])
    return action


# ---- the parser ----------------------------------------------------------------------------
class ReplyError(ValueError):
    """A reply that is not exactly one well-formed call (the message is the reason)."""


def parse_reply(reply, net_names: Sequence[str], max_candidates: int) -> Parsed:
    """The reply as an action, or idle with the reason (never raises)."""
    try:
        verb, raw = _one_call(reply)
        values = _check_arguments(verb, raw, net_names, max_candidates)
    except ReplyError as exc:
        return Parsed(idle_action(), "", str(exc))
    return Parsed(_action(verb, values, net_names), call_text(verb, values), None)


def _one_call(reply) -> tuple[str, dict | list]:
    """(verb, arguments as a dict of names or a list of positional values)."""
    if isinstance(reply, str):
        return _text_call(reply)
    if not isinstance(reply, Mapping):
        raise ReplyError(f"expected text or a tool call, got {type(reply).__name__}")
    calls = reply.get("tool_calls")
    if calls:
        if not isinstance(calls, Sequence) or isinstance(calls, str):
            raise ReplyError("tool_calls must be a list")
        if len(calls) != 1:
            raise ReplyError(f"{len(calls)} tool calls: send exactly one action")
        call = calls[0]
        if not isinstance(call, Mapping):
            raise ReplyError("a tool call must be an object")
        return _structured_call(call.get("function", call))
    if "name" in reply:
        return _structured_call(reply)
    if isinstance(reply.get("content"), str):
        return _text_call(reply["content"])
    raise ReplyError("no tool call and no text in the reply")


def _structured_call(call) -> tuple[str, dict]:
    if not isinstance(call, Mapping) or not isinstance(call.get("name"), str):
        raise ReplyError("a tool call needs a function name")
    verb = _known_verb(call["name"])
    arguments = call.get("arguments", {})
    if isinstance(arguments, str):
        _ascii(arguments)
        try:
            arguments = json.loads(arguments) if arguments.strip() else {}
        except json.JSONDecodeError as exc:
            raise ReplyError(f"{verb}: arguments are not valid JSON ({exc.msg} at "
                             f"character {exc.pos})") from None
    if not isinstance(arguments, Mapping):
        raise ReplyError(f"{verb}: arguments must be a JSON object")
    return verb, dict(arguments)


def _ascii(text: str) -> None:
    bad = next((c for c in text if ord(c) > 127), None)
    if bad is not None:
        raise ReplyError(f"non-ASCII character U+{ord(bad):04X} at position {text.index(bad)}: "
                         f"write calls in ASCII only")


def _known_verb(name: str) -> str:
    _ascii(name)
    if name not in PARAMETERS:
        hint = " (idle is not a verb: send a real action)" if name == "idle" else ""
        raise ReplyError(f"unknown verb {_clip(name)!r}{hint}; verbs: {', '.join(VERBS)}")
    return name


def _clip(text: str) -> str:
    return text if len(text) <= _MAX_SHOWN else text[: _MAX_SHOWN - 3] + "..."


_CALL = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*\((.*)\)", re.DOTALL)
_CALL_START = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\s*\(")


def _text_call(text: str) -> tuple[str, list | dict]:
    _ascii(text)
    body = text.strip().strip("`").strip()
    if not body:
        raise ReplyError("empty reply: send one call such as make_line(3, walkaround)")
    starts = len(_CALL_START.findall(_without_strings(body)))
    if starts > 1:
        raise ReplyError(f"{starts} calls in one reply: send exactly one action")
    match = _CALL.fullmatch(body)
    if not match:
        raise ReplyError(f"not a call: {_clip(body)!r}; write one call such as "
                         f"make_line(3, walkaround)")
    verb = _known_verb(match.group(1))
    return verb, _text_arguments(verb, match.group(2))


def _without_strings(text: str) -> str:
    """The text with quoted strings blanked (a net name may hold parentheses)."""
    return re.sub(r'"(?:[^"\\]|\\.)*"', '""', text)


_TOKEN = re.compile(r'\s*(?:(?P<key>[a-z_]+)\s*=\s*)?(?P<value>"(?:[^"\\]|\\.)*"|[^,"\s]+)\s*'
                    r'(?:,|$)')


def _text_arguments(verb: str, inner: str) -> list | dict:
    """Positional values (list) or keyword values (dict) of a text call."""
    if not inner.strip():
        return []
    if inner.rstrip().endswith(","):
        raise ReplyError(f"{verb}: an argument is missing after the last comma")
    tokens, position = [], 0
    while position < len(inner):
        match = _TOKEN.match(inner, position)
        if not match or match.end() == position:
            raise ReplyError(f"{verb}: cannot read the arguments {_clip(inner)!r}")
        tokens.append((match.group("key"), _text_value(match.group("value"))))
        position = match.end()
    keys = [key for key, _ in tokens]
    if all(key is None for key in keys):
        return [value for _, value in tokens]
    if any(key is None for key in keys):
        raise ReplyError(f"{verb}: use either positional or keyword arguments, not both")
    if len(set(keys)) != len(keys):
        raise ReplyError(f"{verb}: an argument is given twice")
    return dict(tokens)


def _text_value(token: str):
    if token.startswith('"'):
        return json.loads(token)
    if re.fullmatch(r"-?\d+", token):
        return int(token)
    return token  # a bare word: a mode, or a net name without special characters


def _check_arguments(verb: str, raw: list | dict, net_names: Sequence[str],
                     max_candidates: int) -> dict:
    names = PARAMETERS[verb]
    if isinstance(raw, list):
        required = [n for n in names if n not in DEFAULTS]
        if not len(required) <= len(raw) <= len(names):
            raise ReplyError(f"{verb} takes {_arity(verb)}, got {len(raw)}")
        raw = dict(zip(names, raw, strict=False))
    unknown = sorted(set(map(str, raw)) - set(names))
    if unknown:
        raise ReplyError(f"{verb}: unknown argument(s) {unknown}; it takes {_arity(verb)}")
    missing = [n for n in names if n not in raw and n not in DEFAULTS]
    if missing:
        raise ReplyError(f"{verb}: missing argument(s) {missing}; it takes {_arity(verb)}")
    values = {n: raw.get(n, DEFAULTS.get(n)) for n in names}
    for name, value in values.items():
        _check_value(verb, name, value, net_names, max_candidates)
    return values


def _arity(verb: str) -> str:
    names = PARAMETERS[verb]
    if not names:
        return "no arguments"
    shown = [f"{n}={DEFAULTS[n]}" if n in DEFAULTS else n for n in names]
    return f"({', '.join(shown)})"


def _check_value(verb: str, name: str, value, net_names: Sequence[str],
                 max_candidates: int) -> None:
    if name == "point":
        if not isinstance(value, int) or isinstance(value, bool):
            raise ReplyError(f"{verb}: point must be an integer candidate index, got "
                             f"{_clip(json.dumps(value))}")
        if not 0 <= value < max_candidates:
            raise ReplyError(f"{verb}: point {value} out of range [0, {max_candidates})")
    elif name == "mode":
        if value not in MODES:
            raise ReplyError(f"{verb}: unknown mode {_clip(json.dumps(value))}; modes: "
                             f"{', '.join(MODES)}")
    elif not isinstance(value, str) or value not in net_names:
        raise ReplyError(f"{verb}: unknown net {_clip(json.dumps(value))}")

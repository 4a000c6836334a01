"""Parsing an action: anything the agent sends becomes either a clean `Action` or a reason why
it is malformed (wrong type or shape, NaN, out-of-range index); never an exception."""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from pcbdata.env.types import ACTION_TYPES, MODES

ARGUMENTS = ("type", "net", "candidate", "mode")


@dataclass(frozen=True)
class Action:
    type: int
    net: int
    candidate: int
    mode: int


def action_space(max_nets: int, max_candidates: int) -> spaces.Dict:
    return spaces.Dict({"type": spaces.Discrete(len(ACTION_TYPES)),
                        "net": spaces.Discrete(max_nets),
                        "candidate": spaces.Discrete(max_candidates),
                        "mode": spaces.Discrete(len(MODES))})


def _index(value, size: int, name: str) -> tuple[int | None, str | None]:
    try:
        array = np.asarray(value)
    except Exception:  # noqa: BLE001 - any object the agent sends
        return None, f"{name}: not a number"
    if array.shape not in ((), (1,)) or array.dtype.kind not in "iufb":
        return None, f"{name}: expected one integer, got {type(value).__name__} {array.shape}"
    number = float(array.reshape(()))
    if not math.isfinite(number) or number != int(number):
        return None, f"{name}: {number} is not an integer"
    if not 0 <= number < size:
        return None, f"{name}: {int(number)} out of range [0, {size})"
    return int(number), None


def _size(space: spaces.Dict, name: str) -> int:
    sub = space[name]
    assert isinstance(sub, spaces.Discrete)
    return int(sub.n)


def parse_action(raw, space: spaces.Dict) -> tuple[Action | None, str | None]:
    """(Action, None) or (None, reason)."""
    if not isinstance(raw, Mapping):
        return None, f"malformed action: expected a dict with {', '.join(ARGUMENTS)}, " \
                     f"got {type(raw).__name__}"
    unknown = sorted(set(map(str, raw)) - set(ARGUMENTS))
    if unknown:
        return None, f"malformed action: unknown keys {unknown}"
    values = {}
    for name in ARGUMENTS:
        if name not in raw:
            values[name] = 0  # arguments the action type does not use may be left out
            continue
        value, reason = _index(raw[name], _size(space, name), name)
        if reason or value is None:
            return None, f"malformed action: {reason}"
        values[name] = value
    return Action(**values), None


def needs(action_type: int) -> tuple[str, ...]:
    """The arguments an action type reads."""
    return {1: ("net",), 3: ("candidate",), 4: ("candidate", "mode"), 5: ("candidate", "mode"),
            6: ("mode",)}.get(action_type, ())

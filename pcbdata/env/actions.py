"""Parsing an action: anything the agent sends becomes either a clean `Action` or a reason why
it is malformed (wrong type or shape, NaN, out-of-range index); never an exception.

Two forms share the action dict: the candidate-index form of SPEC section 6 (`type`, `net`,
`candidate`, `mode`: the declared `action_space`), and pcbdata's free-coordinate form (the
paper's action surface, SPEC 7.1): `x`, `y` in mm (both or neither) and, for `start_route` (and
a `make_via` to an inner layer), `layer`, a layer index. With `x` and `y` the point replaces the
candidate; the environment checks it (`RoutingEnv`: a `start_route` point must be a pad centre,
track end or via of the net within `POINT_TOLERANCE_NM`; a line or via end must lie inside the
outline)."""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from pcbdata.env.types import ACTION_TYPES, MODES

ARGUMENTS = ("type", "net", "candidate", "mode")
#: The free-coordinate form's keys (not in `action_space`: index agents never send them).
POINT_ARGUMENTS = ("x", "y", "layer")
#: Largest coordinate accepted, in mm (KiCad clamps far-out coordinates silently).
MAX_MM = 1e5


@dataclass(frozen=True)
class Action:
    type: int
    net: int
    candidate: int
    mode: int
    point: tuple[int, int] | None = None  # nm; the free-coordinate form
    layer: int | None = None  # a layer index (free-coordinate form)


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
    unknown = sorted(set(map(str, raw)) - set(ARGUMENTS) - set(POINT_ARGUMENTS))
    if unknown:
        return None, f"malformed action: unknown keys {unknown}"
    point, layer, reason = _point(raw)
    if reason:
        return None, f"malformed action: {reason}"
    values = {}
    for name in ARGUMENTS:
        if name not in raw:
            values[name] = 0  # arguments the action type does not use may be left out
            continue
        value, reason = _index(raw[name], _size(space, name), name)
        if reason or value is None:
            return None, f"malformed action: {reason}"
        values[name] = value
    return Action(**values, point=point, layer=layer), None


def _point(raw: Mapping) -> tuple[tuple[int, int] | None, int | None, str | None]:
    """(point in nm, layer, None) of the free-coordinate keys, or (None, None, reason)."""
    layer = None
    if raw.get("layer") is not None:
        layer, reason = _index(raw["layer"], 64, "layer")
        if reason:
            return None, None, reason
    given = [k for k in ("x", "y") if raw.get(k) is not None]
    if not given:
        return None, layer, None
    if len(given) == 1:
        return None, None, f"{given[0]} without {'y' if given[0] == 'x' else 'x'}"
    out = []
    for name in ("x", "y"):
        try:
            value = float(np.asarray(raw[name], dtype=float).reshape(()))
        except (TypeError, ValueError):
            return None, None, f"{name}: expected a number of mm, got {raw[name]!r}"
        if not math.isfinite(value) or abs(value) > MAX_MM:
            return None, None, f"{name}: {value} mm is not a finite coordinate within {MAX_MM:g}"
        out.append(int(round(value * 1e6)))
    return (out[0], out[1]), layer, None


def needs(action_type: int) -> tuple[str, ...]:
    """The arguments an action type reads."""
    return {1: ("net",), 3: ("candidate",), 4: ("candidate", "mode"), 5: ("candidate", "mode"),
            6: ("mode",)}.get(action_type, ())

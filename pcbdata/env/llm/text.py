"""The board as compact s-expressions for a language model, from the environment's raw
observation and `info` only: the static part (layers, rules, outline, nets, pads) once per
episode, the dynamic part (phase, head, tracks, vias, ratsnest, candidates, DRC) per step.

Nets are named (JSON-quoted strings, non-ASCII escaped as \\uXXXX), layers by their KiCad
names, coordinates and sizes in mm with exactly three decimals. Only the observation's arrays
are read, so the same observation always gives the same text.
"""
from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from pcbdata.env.observation import DRC_TYPES, PAD_SHAPES, SEVERITIES
from pcbdata.env.types import CANDIDATE_KINDS, EMPTY, PHASES

_INDENT = "  "


def mm(value) -> str:
    """A length in mm with exactly three decimals ("-0.000" written as "0.000")."""
    text = f"{float(value):.3f}"
    return "0.000" if text == "-0.000" else text


def quote(name: str) -> str:
    return json.dumps(name, ensure_ascii=True)


def _xy(x, y) -> str:
    return f"{mm(x)} {mm(y)}"


class Names:
    """Net and layer names of an episode (`info["net_names"]`, `info["layers"]` at reset)."""

    def __init__(self, net_names: Sequence[str], layers: Sequence[str]):
        self.nets, self.layers = list(net_names), list(layers)

    def net(self, index) -> str:
        i = int(index)
        return quote(self.nets[i]) if 0 <= i < len(self.nets) else "none"

    def layer(self, index) -> str:
        i = int(index)
        return self.layers[i] if 0 <= i < len(self.layers) else "none"


def _block(head: str, items: list[str], depth: int = 1) -> str:
    """`(head item item ...)`, one item per line; `(head)` when empty."""
    if not items:
        return f"{_INDENT * depth}({head})"
    pad = _INDENT * (depth + 1)
    return f"{_INDENT * depth}({head}\n" + "\n".join(pad + i for i in items) + ")"


# ---- static part ----------------------------------------------------------------------------
def static_text(obs: dict, info: dict) -> str:
    names = Names(info["net_names"], info["layers"])
    s = obs["board_static"]
    clearance, width, via, drill, edge = (mm(v) for v in s["rules"])
    rules = (f"(rules (clearance {clearance}) (track_width {width}) (via {via} {drill}) "
             f"(edge_clearance {edge}))")
    return "\n".join([
        f"(board {quote(info['board_id'])}",
        f"{_INDENT}(layers {' '.join(names.layers)})",
        _INDENT + rules,
        _outline(s),
        _nets(s, names, s["rules"]),
        _pads(s, names) + ")"])


def _outline(s: dict) -> str:
    rows = s["outline"][: int(s["outline_count"])]
    rings = []
    for ring in sorted({int(r[2]) for r in rows}):
        points = " ".join(f"({_xy(r[0], r[1])})" for r in rows if int(r[2]) == ring)
        rings.append(f"(ring {ring} {points})")
    return _block("outline", rings)


def _nets(s: dict, names: Names, rules: np.ndarray) -> str:
    """One line per net: index, name, pad count; its rules only where they differ from the
    board's."""
    items = []
    for i, row in enumerate(s["nets"][: len(names.nets)]):
        extra = ""
        if not np.array_equal(row[2:6], rules[:4]):
            extra = (f" (clearance {mm(row[2])}) (track_width {mm(row[3])}) "
                     f"(via {mm(row[4])} {mm(row[5])})")
        items.append(f"(net {i} {names.net(i)} (pads {int(row[1])}){extra})")
    return _block("nets", items)


def _pads(s: dict, names: Names) -> str:
    items = []
    for row, on in zip(s["pads"], s["pad_layers"], strict=True):
        if not row[0]:
            continue
        shape = PAD_SHAPES[int(row[6])] if 0 <= int(row[6]) < len(PAD_SHAPES) else "other"
        layers = " ".join(names.layer(i) for i in np.flatnonzero(on))
        drill = f" (drill {mm(row[7])})" if row[7] > 0 else ""
        items.append(f"(pad {names.net(row[1])} (at {_xy(row[2], row[3])}) "
                     f"(size {_xy(row[4], row[5])}) {shape.lower()}{drill} (layers {layers}))")
    return _block("pads", items)


# ---- dynamic part ---------------------------------------------------------------------------
def dynamic_text(obs: dict, info: dict, names: Names) -> str:
    """The state of a step: phase, net, head, counts, copper, open connections, candidates and
    DRC violations."""
    geo, head = obs["routing_geometry"], obs["router_head"]
    return "\n".join([
        f"(state (step {int(obs['step'])}) (phase {PHASES[int(head['phase'])]}) "
        f"(net {names.net(head['net'])}) {_head(head, names)}",
        f"{_INDENT}(unconnected {int(geo['unconnected'])}) (violations "
        f"{int(obs['drc']['total'])})",
        _tracks(geo, names),
        _vias(geo, names),
        _ratsnest(geo, names),
        _candidates(head, info["action_mask"], names),
        _violations(obs["drc"], names) + ")"])


def _head(head: dict, names: Names) -> str:
    if int(head["layer"]) < 0:
        return "(head none)"
    x, y = head["position"]
    return f"(head (at {_xy(x, y)}) (layer {names.layer(head['layer'])}))"


def _tracks(geo: dict, names: Names) -> str:
    items = []
    for r in geo["tracks"][: int(geo["track_count"])]:
        kind = "arc" if r[3] else "track"
        items.append(f"({kind} {names.net(r[1])} {names.layer(r[2])} (from {_xy(r[4], r[5])}) "
                     f"(to {_xy(r[6], r[7])}) (width {mm(r[8])}))")
    return _block("tracks", items)


def _vias(geo: dict, names: Names) -> str:
    return _block("vias", [f"(via {names.net(r[1])} (at {_xy(r[2], r[3])}) "
                           f"(size {mm(r[4])} {mm(r[5])}))"
                           for r in geo["vias"][: int(geo["via_count"])]])


def _ratsnest(geo: dict, names: Names) -> str:
    return _block("ratsnest", [f"(open {names.net(r[1])} (from {_xy(r[2], r[3])}) "
                               f"(to {_xy(r[4], r[5])}))"
                               for r in geo["ratsnest"][: int(geo["ratsnest_count"])]])


def _candidates(head: dict, mask: dict, names: Names) -> str:
    """Non-empty candidate slots with their index and what they are allowed for (`start`,
    `line`, `via`)."""
    items = []
    routing = int(head["layer"]) >= 0
    for i, c in enumerate(head["candidates"]):
        if int(c[0]) == EMPTY:
            continue
        uses = []
        if mask["candidate"][i]:
            uses.append("line" if routing else "start")
        if mask["candidate_via"][i]:
            uses.append("via")
        allowed = f" (allowed {' '.join(uses)})" if uses else " (masked)"
        items.append(f"(c {i} {CANDIDATE_KINDS[int(c[0])]} (at {_xy(c[1], c[2])}) "
                     f"{names.layer(c[3])}{allowed})")
    return _block("candidates", items)


def _violations(drc: dict, names: Names) -> str:
    items = []
    for r in drc["violations"][: int(drc["count"])]:
        nets = " ".join(names.net(n) for n in r[5:7] if int(n) >= 0)
        items.append(f"({DRC_TYPES[int(r[1])]} {SEVERITIES[int(r[2])]} (at {_xy(r[3], r[4])})"
                     + (f" (nets {nets}))" if nets else ")"))
    return _block("drc", items)

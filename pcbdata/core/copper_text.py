"""The tracks, arcs and vias a board file itself holds, read from its text before KiCad parses it.

KiCad drops a `segment` or `arc` on a layer that is not copper (Dwgs.User, Edge.Cuts, F.Mask)
while loading, and clamps a coordinate beyond its range (2^31 - 1 nm, about 2.1 m) to the
limit: what KiCad loaded cannot show either. Pure (standard library, numpy).
"""
from __future__ import annotations

import math
import re

#: KiCad's coordinate range: a board unit is a 32-bit signed integer of nanometres.
MAX_NM = 2**31 - 1
COPPER_HEADS = {"segment": "track", "arc": "arc", "via": "via"}
_QUOTED = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
_HEAD = re.compile(rb'\(\s*([^\s()"]+)')
SEXPR_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|[()]|[^\s()"]+')
_POINTS = ("start", "mid", "end", "at")


def _mask(match: re.Match) -> bytes:
    return b'"' + b"_" * (len(match.group()) - 2) + b'"'


def top_level_blocks(data: bytes) -> list[tuple[str, int, int]]:
    """(head, start, end) of every child block of the file's first expression, in order.
    Brackets inside quoted strings do not count (they are masked, offsets kept)."""
    import numpy as np

    masked = np.frombuffer(_QUOTED.sub(_mask, data), dtype=np.uint8)
    where = np.flatnonzero((masked == ord("(")) | (masked == ord(")")))
    opens = masked[where] == ord("(")
    depth = np.cumsum(np.where(opens, 1, -1))
    starts = where[opens & (depth == 2)]
    ends = where[~opens & (depth == 1)] + 1
    blocks = []
    for start, end in zip(starts.tolist(), ends.tolist()):
        head = _HEAD.match(data, start)
        blocks.append((head.group(1).decode("ascii", "replace") if head else "", start, end))
    return blocks


def _fields(block: str) -> tuple[list[str], dict[str, list[str]]]:
    """(atoms after the head, {child head: its atoms}) of one block; deeper levels ignored,
    the last child of a head wins (as KiCad's parser overwrites)."""
    atoms: list[str] = []
    fields: dict[str, list[str]] = {}
    depth = 0
    current: list[str] | None = None
    for token in SEXPR_TOKEN.findall(block):
        if token == "(":
            depth += 1
            current = [] if depth == 2 else None
        elif token == ")":
            depth -= 1
        elif depth == 1:
            atoms.append(token)
        elif depth == 2 and current is not None:
            if not current and token:
                current.append(token)
                fields[token] = current
            else:
                current.append(token)
    return atoms[1:], {head: values[1:] for head, values in fields.items()}


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def copper_in_file(data: bytes) -> list[dict]:
    """The file's top-level tracks, arcs and vias: kind (track / arc / via), layers (names as
    written; a via's pair, a track's one layer, empty when absent) and points in mm by field
    (start, mid, end, at)."""
    items = []
    for head, start, end in top_level_blocks(data):
        kind = COPPER_HEADS.get(head)
        if kind is None:
            continue
        _, fields = _fields(data[start:end].decode("utf-8", "replace"))
        layers = fields.get("layers") if kind == "via" else fields.get("layer")
        points = {key: [_number(v) for v in fields[key][:2]] for key in _POINTS if key in fields}
        items.append({"kind": kind, "layers": [n.strip('"') for n in layers or []],
                      "points": points})
    return items


def _where(item: dict) -> str:
    point = item["points"].get("at") or item["points"].get("start") or [math.nan, math.nan]
    return f"{item['kind']} at ({', '.join(f'{v:g}' for v in point)}) mm"


def out_of_range(item: dict) -> bool:
    """Whether a coordinate of the item is beyond KiCad's range (KiCad would clamp it)."""
    return any(not abs(v) * 1e6 <= MAX_NM for pt in item["points"].values() for v in pt)


def _summary(found: list[dict], what: str, detail) -> str | None:
    if not found:
        return None
    more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
    return f"{_where(found[0])} {what}{detail(found[0])}{more}"


def file_problems(items: list[dict], copper_layers: set[str]) -> list[str]:
    """Why the file's own copper cannot be scored as KiCad would load it: coordinates beyond
    KiCad's range, or layers that are not copper layers of the instance (`copper_layers`:
    every name the instance's copper layers go by)."""
    far = [item for item in items if out_of_range(item)]
    off = [item for item in items if any(n not in copper_layers for n in item["layers"])]
    problems = [
        _summary(far, "has a coordinate outside KiCad's range (+-2147.48 mm)", lambda i: ""),
        _summary(off, "is on a layer the instance has no copper on",
                 lambda i: f" ({', '.join(i['layers'])})"),
    ]
    return [p for p in problems if p]


def kind_counts(items: list[dict]) -> dict[str, int]:
    counts = dict.fromkeys(COPPER_HEADS.values(), 0)
    for item in items:
        counts[item["kind"]] += 1
    return counts

"""Derived inputs of the set policy: relations between rows that a set encoder cannot see from
one row alone, and the agent's memory of its own episode (docs/learn.md, "The network").

A DeepSets encoder reads each row with a pooled summary of all rows, so it cannot tell which
candidate sits at the end of an open ratsnest edge of the head's net, or that its last `finish`
changed nothing and the same observation is back. Both are cheap to compute here, from the RL
wrapper's table and the agent's own past actions (what a recurrent policy would have to
learn to remember), and both are needed to imitate the scripted agent, whose choices depend
on them. Pure numpy; positions in the table's normalised frame.
"""
from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from pcbdata.env.types import ACTION_TYPES, FINISH, MAKE_VIA, MODES, NET_SELECT, START_ROUTE
from pcbdata.env.wrappers import features as F

#: Derived columns, each family filling its own slots (the others stay 0).
NET_COLUMNS = ("open_edges", "shortest_edge", "half_perimeter", "times_selected")
CANDIDATE_COLUMNS = ("distance_to_head", "at_head", "edge_end", "first_end", "edge_length",
                     "layer_shared", "times_started")
HEAD_COLUMNS = (tuple(f"last_{t}" for t in ACTION_TYPES) + tuple(f"last_{m}" for m in MODES)
                + ("last_changed_nothing",) + tuple(f"finish_{m}_failed_here" for m in MODES)
                + ("via_here", "on_drilled_pad", "net_open_edges"))
NET0 = 0
CAND0 = NET0 + len(NET_COLUMNS)
HEAD0 = CAND0 + len(CANDIDATE_COLUMNS)
WIDTH = HEAD0 + len(HEAD_COLUMNS)
#: A net the scripted agent gave up after this many starts; counts are divided by it.
TRIES = 6.0


def _same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a - b) < 1e-6


@dataclass
class Memory:
    """The agent's record of its own episode: what it did and where it got nowhere."""

    last: tuple[int, int, int] | None = None
    before: bytes = b""
    head_before: tuple[float, float, float] = (0.0, 0.0, -1.0)
    changed_nothing: bool = False
    failed: set[tuple] = field(default_factory=set)  # (head, mode) of finishes that did nothing
    selected: dict[int, int] = field(default_factory=dict)
    started: dict[tuple, int] = field(default_factory=dict)  # (net, x, y, layer) -> starts
    vias: set[tuple] = field(default_factory=set)  # (x, y) where it dropped a via


def fingerprint(wrapped: Mapping[str, np.ndarray]) -> bytes:
    """The observation without its step counters: equal when an action changed nothing."""
    table = np.array(wrapped["entities"], dtype=np.float32)
    types = np.asarray(wrapped["entity_type"])
    table[types == F.BOARD, F.B] = 0.0
    table[types == F.HEAD, F.COUNT] = 0.0
    digest = hashlib.blake2b(table.tobytes(), digest_size=16)
    digest.update(np.asarray(wrapped["entity_mask"], dtype=np.int8).tobytes())
    return digest.digest()


def head_of(wrapped: Mapping[str, np.ndarray]) -> tuple[tuple[float, float, float], int]:
    """((x, y, layer) of the router head, its net index or -1)."""
    types = np.asarray(wrapped["entity_type"])
    row = int(np.flatnonzero(types == F.HEAD)[0])
    t = wrapped["entities"][row]
    net = int(wrapped["entity_net"][row, 0])
    return (float(t[F.X1]), float(t[F.Y1]), float(t[F.LAYER_LO])), net


def observe(memory: Memory, wrapped: Mapping[str, np.ndarray]) -> bytes:
    """Updates the memory with the observation the agent is about to act on; returns its
    fingerprint (for `acted`)."""
    now = fingerprint(wrapped)
    memory.changed_nothing = memory.last is not None and now == memory.before
    if memory.changed_nothing and memory.last is not None and memory.last[0] == FINISH:
        memory.failed.add((memory.head_before, memory.last[2]))
    return now


def acted(memory: Memory, wrapped: Mapping[str, np.ndarray], seen: bytes,
          triple: tuple[int, int, int]) -> None:
    """Records the action taken on `wrapped` (whose fingerprint `observe` gave as `seen`)."""
    head, net = head_of(wrapped)
    kind, index, _ = triple
    memory.last, memory.before, memory.head_before = triple, seen, head
    if kind == NET_SELECT:
        memory.selected[index] = memory.selected.get(index, 0) + 1
    elif kind == START_ROUTE:
        key = (net, *_candidate_key(wrapped, index))
        memory.started[key] = memory.started.get(key, 0) + 1
    elif kind == MAKE_VIA:
        memory.vias.add(head[:2])


def _candidate_key(wrapped, index: int) -> tuple[float, float, float]:
    types = np.asarray(wrapped["entity_type"])
    row = wrapped["entities"][np.flatnonzero(types == F.CANDIDATE)[index]]
    return float(row[F.X1]), float(row[F.Y1]), float(row[F.LAYER_LO])


def derived_rows(wrapped: Mapping[str, np.ndarray], memory: Memory) -> np.ndarray:
    """[rows, WIDTH] float32: the derived columns of every row of the wrapped table."""
    table = np.asarray(wrapped["entities"], dtype=np.float64)
    types = np.asarray(wrapped["entity_type"])
    nets = np.asarray(wrapped["entity_net"])
    valid = np.asarray(wrapped["entity_mask"]).astype(bool)
    out = np.zeros((len(table), WIDTH), dtype=np.float32)
    edges = np.flatnonzero((types == F.RATSNEST) & valid)
    head, head_net = head_of(wrapped)
    _net_columns(table, types, nets, edges, memory, out)
    _candidate_columns(table, types, nets, valid, edges, head, head_net, memory, out)
    _head_columns(table, types, nets, valid, edges, head, head_net, memory, out)
    return out


def _net_columns(table, types, nets, edges, memory: Memory, out) -> None:
    rows = np.flatnonzero(types == F.NET)
    index = nets[rows, 0]
    edge_net, length = nets[edges, 0], table[edges, F.S1]
    for r, n in zip(rows, index, strict=True):
        if n < 0:
            continue
        mine = length[edge_net == n]
        out[r, NET0:CAND0] = (np.log1p(len(mine)), mine.min() if len(mine) else 0.0,
                              table[r, F.X2] - table[r, F.X1] + table[r, F.Y2] - table[r, F.Y1],
                              memory.selected.get(int(n), 0) / TRIES)


def _candidate_columns(table, types, nets, valid, edges, head, head_net, memory, out) -> None:
    rows = np.flatnonzero((types == F.CANDIDATE) & valid)
    if not len(rows):
        return
    x, y, layer = table[rows, F.X1], table[rows, F.Y1], table[rows, F.LAYER_LO]
    c = out[rows]
    c[:, CAND0] = np.hypot(x - head[0], y - head[1])
    c[:, CAND0 + 1] = _same(x, head[0]) & _same(y, head[1]) & _same(layer, head[2])
    pads = np.flatnonzero((types == F.PAD) & valid)
    best = np.full(len(rows), np.inf)
    for e in edges[nets[edges, 0] == head_net] if head_net >= 0 else []:
        ends = ((table[e, F.X1], table[e, F.Y1]), (table[e, F.X2], table[e, F.Y2]))
        for end, (ex, ey) in enumerate(ends):
            hit = _same(x, ex) & _same(y, ey) & (table[e, F.S1] < best)
            if not hit.any():
                continue
            ox, oy = ends[1 - end]
            other = pads[_same(table[pads, F.X1], ox) & _same(table[pads, F.Y1], oy)]
            shared = np.zeros(len(rows), dtype=bool)
            for p in other:
                shared |= (layer >= table[p, F.LAYER_LO] - 1e-6) \
                    & (layer <= table[p, F.LAYER_HI] + 1e-6)
            best[hit] = table[e, F.S1]
            c[hit, CAND0 + 2] = 1.0
            c[hit, CAND0 + 3] = float(end == 0)
            c[hit, CAND0 + 4] = table[e, F.S1]
            c[hit, CAND0 + 5] = shared[hit]
    c[:, CAND0 + 6] = [memory.started.get((head_net, float(a), float(b), float(la)), 0) / TRIES
                       for a, b, la in zip(x, y, layer, strict=True)]
    out[rows] = c


def _head_columns(table, types, nets, valid, edges, head, head_net, memory, out) -> None:
    row = int(np.flatnonzero(types == F.HEAD)[0])
    h = out[row]
    if memory.last is not None:
        h[HEAD0 + memory.last[0]] = 1.0
        h[HEAD0 + len(ACTION_TYPES) + memory.last[2]] = 1.0
    at = HEAD0 + len(ACTION_TYPES) + len(MODES)
    h[at] = memory.changed_nothing
    for m in range(len(MODES)):
        h[at + 1 + m] = (head, m) in memory.failed
    at += 1 + len(MODES)
    pads = (types == F.PAD) & valid
    on_pad = pads & _same(table[:, F.X1], head[0]) & _same(table[:, F.Y1], head[1])
    h[at] = head[:2] in memory.vias
    h[at + 1] = bool((table[on_pad, F.S3] > 0).any())
    h[at + 2] = np.log1p(int((nets[edges, 0] == head_net).sum())) if head_net >= 0 else 0.0
    out[row] = h


class EpisodeReader:
    """One environment's view for the network: `read` an observation (memory updated,
    compacted with the derived columns), then `acted` with the action taken on it;
    `reset` at a new episode."""

    def __init__(self) -> None:
        self.memory = Memory()
        self._pending: tuple[Mapping, bytes] | None = None

    def reset(self) -> None:
        self.memory, self._pending = Memory(), None

    def read(self, wrapped: Mapping[str, np.ndarray]) -> np.ndarray:
        seen = observe(self.memory, wrapped)
        self._pending = (wrapped, seen)
        return derived_rows(wrapped, self.memory)

    def acted(self, triple) -> None:
        if self._pending is None:
            raise RuntimeError("acted() without read()")
        wrapped, seen = self._pending
        kind, index, mode = (int(v) for v in triple)
        acted(self.memory, wrapped, seen, (kind, index, mode))
        self._pending = None

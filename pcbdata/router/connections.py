"""The connections a board needs, as the negotiated planner takes them: per net, a minimum
spanning tree over its pad clusters (`spanning_connections`), shortest first, or in a seeded
order (`seeded_order`). Plain data, no KiCad."""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

from pcbdata.router.geometry import Point


@dataclass(frozen=True)
class End:
    """One end of a connection: a pad centre, the copper layers it is on, and how far its
    copper reaches from the centre (for via spots beside it)."""

    x: int
    y: int
    layers: tuple[str, ...]
    reach: int = 0

    @property
    def at(self) -> Point:
        return (self.x, self.y)


@dataclass(frozen=True)
class Connection:
    net: str
    a: End
    b: End

    @property
    def length(self) -> float:
        return math.hypot(self.a.x - self.b.x, self.a.y - self.b.y)


def spanning_connections(pads: list[tuple[str, End, int]]) -> list[Connection]:
    """Per net, a minimum spanning tree over its pad clusters: `pads` are (net, end, cluster);
    pads of one cluster are joined already. Edges by the shortest pad-to-pad distance between
    two clusters (ties by coordinates), shortest first over the whole board."""
    by_net: dict[str, list[tuple[End, int]]] = {}
    for net, end, cluster in pads:
        by_net.setdefault(net, []).append((end, cluster))
    out: list[Connection] = []
    for net in sorted(by_net):
        out += _net_tree(net, by_net[net])
    return sorted(out, key=lambda c: (c.length, c.net, c.a.at, c.b.at))


def seeded_order(connections: list[Connection], seed: int) -> list[Connection]:
    """The connections shortest first (seed 0), or by length times a seeded factor in [1, 1.5)
    (other seeds: another order per rollout, from a hash, the same on every machine)."""
    if seed == 0:
        return list(connections)

    def key(c: Connection) -> tuple:
        digest = hashlib.sha256(f"{seed}:{c.net}:{c.a.at}:{c.b.at}".encode()).digest()
        return (c.length * (1 + 0.5 * int.from_bytes(digest[:8], "big") / 2 ** 64),
                c.net, c.a.at, c.b.at)

    return sorted(connections, key=key)


def _net_tree(net: str, pads: list[tuple[End, int]]) -> list[Connection]:
    clusters = sorted({c for _, c in pads})
    if len(clusters) < 2:
        return []
    best: dict[tuple[int, int], tuple[float, End, End]] = {}
    for i, (p, cp) in enumerate(pads):
        for q, cq in pads[i + 1:]:
            if cp == cq:
                continue
            key = (min(cp, cq), max(cp, cq))
            d = math.hypot(p.x - q.x, p.y - q.y)
            ends = (p, q) if (p.x, p.y) <= (q.x, q.y) else (q, p)
            if key not in best or (d, ends[0].at, ends[1].at) < (best[key][0], best[key][1].at,
                                                                  best[key][2].at):
                best[key] = (d, *ends)
    parent = {c: c for c in clusters}

    def root(c: int) -> int:
        while parent[c] != c:
            parent[c] = parent[parent[c]]
            c = parent[c]
        return c

    out = []
    for key, (_, a, b) in sorted(best.items(), key=lambda kv: (kv[1][0], kv[0])):
        ra, rb = root(key[0]), root(key[1])
        if ra != rb:
            parent[ra] = rb
            out.append(Connection(net, a, b))
    return out

"""The ratsnest as pcbdata draws it (a leaf: standard library only), shared by the routing
environment's observation and `pcbdata render`: per net, a minimum spanning tree over the pad
clusters KiCad's connectivity gives, each edge between the closest pad centres."""
from __future__ import annotations

from functools import lru_cache

#: Nets whose answer is remembered (`_net_pairs`): an environment asks at every step, and a
#: net's answer changes only where its pads' clusters do.
REMEMBERED_NETS = 8192


def open_pairs(points: list[tuple[int, int]], net_pads: list[list[int]],
               labels: list[int]) -> list[tuple[int, int]]:
    """(pad, pad) index pairs of the open connections: for each net (its pad indices, in the
    order given), pairs of pads in different clusters (`labels`), closest first (ties by
    index), kept while they join two clusters not yet joined.

    A net's pairs depend only on its pads' points and on which of them share a cluster (not
    on the labels' values), and are remembered under those."""
    out: list[tuple[int, int]] = []
    for pads in net_pads:
        if len(pads) < 2:
            continue
        names: dict[int, int] = {}
        groups = tuple(names.setdefault(labels[p], len(names)) for p in pads)
        if len(names) < 2:
            continue
        out += _net_pairs(tuple(pads), tuple(points[p] for p in pads), groups)
    return out


@lru_cache(maxsize=REMEMBERED_NETS)
def _net_pairs(pads: tuple[int, ...], points: tuple[tuple[int, int], ...],
               groups: tuple[int, ...]) -> tuple[tuple[int, int], ...]:
    """One net's open pairs (`open_pairs`): pads, their points and their clusters numbered in
    the order they first appear. Kruskal over the pairs of pads in different clusters, in
    the order (squared distance, pad, pad), until the clusters are joined."""
    pairs = sorted(((points[i][0] - points[j][0]) ** 2 + (points[i][1] - points[j][1]) ** 2,
                    pads[i], pads[j], i, j)
                   for i in range(len(pads)) for j in range(i + 1, len(pads))
                   if groups[i] != groups[j])
    parent = list(range(max(groups) + 1))
    left = len(parent) - 1  # joins still to make
    out = []
    for _, a, b, i, j in pairs:
        ra, rb = _root(parent, groups[i]), _root(parent, groups[j])
        if ra != rb:
            parent[ra] = rb
            out.append((a, b))
            left -= 1
            if not left:
                break
    return tuple(out)


def _root(parent: list[int], key: int) -> int:
    while parent[key] != key:
        parent[key] = parent[parent[key]]
        key = parent[key]
    return key

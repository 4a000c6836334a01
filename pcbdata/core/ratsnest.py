"""The ratsnest as pcbdata draws it (a leaf: standard library only), shared by the routing
environment's observation and `pcbdata render`: per net, a minimum spanning tree over the pad
clusters KiCad's connectivity gives, each edge between the closest pad centres."""
from __future__ import annotations


def open_pairs(points: list[tuple[int, int]], net_pads: list[list[int]],
               labels: list[int]) -> list[tuple[int, int]]:
    """(pad, pad) index pairs of the open connections: for each net (its pad indices, in the
    order given), pairs of pads in different clusters (`labels`), closest first (ties by
    index), kept while they join two clusters not yet joined."""
    out = []
    for pads in net_pads:
        pairs = sorted(((points[a][0] - points[b][0]) ** 2 + (points[a][1] - points[b][1]) ** 2,
                        a, b) for k, a in enumerate(pads) for b in pads[k + 1:]
                       if labels[a] != labels[b])
        parent = {labels[p]: labels[p] for p in pads}
        for _, a, b in pairs:
            ra, rb = _root(parent, labels[a]), _root(parent, labels[b])
            if ra != rb:
                parent[ra] = rb
                out.append((a, b))
    return out


def _root(parent: dict, key: int) -> int:
    while parent[key] != key:
        key = parent[key]
    return key

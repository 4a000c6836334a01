"""The ratsnest (`pcbdata.core.ratsnest.open_pairs`): per net, Kruskal over the pairs of pads in
different clusters, closest first, ties by index; the remembered, early-stopping form gives the
plain definition's pairs in its order, whatever the clusters' labels."""
from __future__ import annotations

import random

import pytest

from pcbdata.core.ratsnest import _net_pairs, open_pairs


def _definition(points, net_pads, labels):
    """The ratsnest as defined: every pair of a net's pads in different clusters, sorted by
    (squared distance, pad, pad), kept where it joins two clusters not yet joined."""
    out = []
    for pads in net_pads:
        pairs = sorted(((points[a][0] - points[b][0]) ** 2 + (points[a][1] - points[b][1]) ** 2,
                        a, b) for k, a in enumerate(pads) for b in pads[k + 1:]
                       if labels[a] != labels[b])
        joined = {labels[p]: {labels[p]} for p in pads}
        for _, a, b in pairs:
            if joined[labels[a]] is not joined[labels[b]]:
                merged = joined[labels[a]] | joined[labels[b]]
                for label in merged:
                    joined[label] = merged
                out.append((a, b))
    return out


@pytest.mark.parametrize("seed", range(6))
def test_open_pairs_are_the_definitions_for_any_labels(seed):
    rng = random.Random(seed)
    n = rng.randrange(20, 120)
    grid = rng.choice((1, 3, 1_000_000))  # a coarse grid makes ties in distance
    points = [(rng.randrange(0, 12) * grid, rng.randrange(0, 12) * grid) for _ in range(n)]
    order = list(range(n))
    rng.shuffle(order)
    net_pads, at = [], 0
    while at < n:
        size = rng.randrange(1, 25)
        net_pads.append(order[at:at + size])
        at += size
    for _ in range(4):  # copper laid: fewer clusters each time
        labels = [rng.randrange(0, max(1, n // rng.choice((1, 2, 5)))) for _ in range(n)]
        want = _definition(points, net_pads, labels)
        assert open_pairs(points, net_pads, labels) == want
        renamed = {label: rng.randrange(10**6) * 1000 + label for label in set(labels)}
        assert open_pairs(points, net_pads, [renamed[x] for x in labels]) == want


def test_a_joined_net_has_no_pairs_and_answers_are_remembered():
    points = [(0, 0), (10, 0), (20, 0), (30, 0)]
    assert open_pairs(points, [[0, 1, 2, 3]], [7, 7, 7, 7]) == []
    _net_pairs.cache_clear()
    first = open_pairs(points, [[0, 1, 2, 3]], [1, 2, 2, 3])
    assert first == [(0, 1), (2, 3)]
    assert open_pairs(points, [[0, 1, 2, 3]], [5, 9, 9, 4]) == first  # the same partition
    assert _net_pairs.cache_info().hits == 1

"""The searches' work per expansion, compiled: the node to expand next (`_pick`), the nodes
whose cost it lowers (`_targets`), which of their links the ray screen rules out (`_screen`)
and the segments of the links still in question (`_batch_segments`).

Each expansion of `pcbdata.router.search._Search` (and of the layered search's layers) looks
at every node of the window and checks the links from one node to many: their one-bend
variants, the segment ends' ray bounds, the segments left to the exact clearance test. In
numpy that is some fifty small array calls per expansion, which on real boards cost more
than the arithmetic. These kernels do the same arithmetic, in the same order and precision
(integer differences, then the same float operations), in one compiled pass each (numba), so
their answers are the numpy form's exactly: the same nodes, costs, links and segments in the
same order, hence the same searches, plans and episodes (tests/router/test_search_kernel.py,
and whole plans both ways in tests/env/test_negotiated.py). They run where the compiled
clearance test runs (`clearance_kernel.enabled()`, read once per search); otherwise the numpy
form runs alone.
"""
from __future__ import annotations

import numpy as np

from pcbdata.router.clearance import _ROOT2
from pcbdata.router.clearance_kernel import _jit


@_jit
def _sign(x):
    return 1 if x > 0 else (-1 if x < 0 else 0)


@_jit
def _diagonal(dx, dy):
    """The 45-degree part (gx, gy) of a one-bend link by (dx, dy), and its length along an axis."""
    m = min(abs(dx), abs(dy))
    return _sign(dx) * m, _sign(dy) * m, m


@_jit
def _heading(sx, sy, index):
    return index[sx + 1, sy + 1]


@_jit
def _reverse(h):
    return (h + 4) % 8 if h >= 0 else -1


@_jit
def _screen(nodes, v, targets, rows, free, index):
    """(maybe (2, n) bool, missing codes): whether link variant 0 / 1 from node v to each
    target may be clear (a segment longer than its end's ray bound rules its variant out),
    and the (row * 8 + heading) codes of the ray bounds still unknown (NaN in `free`), sorted
    and unique; with any missing, `maybe` is not yet the answer."""
    n = targets.shape[0]
    maybe = np.ones((2, n), dtype=np.bool_)
    vx = nodes[v, 0]
    vy = nodes[v, 1]
    v_row = rows[v]
    codes = np.empty(4 * n, dtype=np.int64)
    k = 0
    for j in range(n):
        t = targets[j]
        dx = nodes[t, 0] - vx
        dy = nodes[t, 1] - vy
        gx, gy, m = _diagonal(dx, dy)
        sx = dx - gx
        sy = dy - gy
        h_straight = _heading(_sign(sx), _sign(sy), index)
        h_diag = _heading(_sign(gx), _sign(gy), index)
        len_straight = float(max(abs(sx), abs(sy)))
        len_diag = m * _ROOT2
        t_row = rows[t]
        # variant 0: straight from v, then diagonal into t (seen from t: reversed);
        # variant 1: diagonal from v, then straight into t
        for variant in range(2):
            if variant == 0:
                h1, l1, h2, l2 = h_straight, len_straight, _reverse(h_diag), len_diag
            else:
                h1, l1, h2, l2 = h_diag, len_diag, _reverse(h_straight), len_straight
            first, k = _too_long(free, v_row, h1, l1, codes, k)
            second, k = _too_long(free, t_row, h2, l2, codes, k)
            maybe[variant, j] = not (first or second)
    return maybe, np.unique(codes[:k])


@_jit
def _too_long(free, row, heading, length, codes, k):
    """Whether a segment of `length` from the node of `row` along `heading` (-1: none) is
    longer than its ray bound; an unknown bound is noted in `codes` (at `k`, the next free
    place, returned) and rules nothing out."""
    if heading < 0:
        return False, k
    bound = free[row, heading]
    if np.isnan(bound):
        codes[k] = row * 8 + heading
        return False, k + 1
    return length > bound, k


@_jit
def _batch_segments(a, ends, maybe):
    """The link batch's segments (k, 2, 2) float and the ends' indices: links that are one
    octilinear segment (`direct`), then the two-segment links of variant 0 and of variant 1
    still in question (`bent0`, `bent1`); segments in the order direct, variant 0's first
    segments, its second segments, variant 1's first segments, its second segments."""
    n = ends.shape[0]
    direct = np.empty(n, dtype=np.int64)
    bent0 = np.empty(n, dtype=np.int64)
    bent1 = np.empty(n, dtype=np.int64)
    nd = n0 = n1 = 0
    ax = a[0]
    ay = a[1]
    for j in range(n):
        dx = ends[j, 0] - ax
        dy = ends[j, 1] - ay
        straight = dx == 0 or dy == 0 or abs(dx) == abs(dy)
        if straight:
            if maybe[0, j] or maybe[1, j]:
                direct[nd] = j
                nd += 1
        else:
            if maybe[0, j]:
                bent0[n0] = j
                n0 += 1
            if maybe[1, j]:
                bent1[n1] = j
                n1 += 1
    segments = np.empty((nd + 2 * n0 + 2 * n1, 2, 2), dtype=np.float64)
    at = 0
    for i in range(nd):
        j = direct[i]
        segments[at, 0, 0] = ax
        segments[at, 0, 1] = ay
        segments[at, 1, 0] = ends[j, 0]
        segments[at, 1, 1] = ends[j, 1]
        at += 1
    for variant in range(2):
        picked = bent0 if variant == 0 else bent1
        count = n0 if variant == 0 else n1
        for half in range(2):
            for i in range(count):
                j = picked[i]
                gx, gy, _ = _diagonal(ends[j, 0] - ax, ends[j, 1] - ay)
                if variant == 0:  # straight, then 45 degrees
                    kx = ends[j, 0] - gx
                    ky = ends[j, 1] - gy
                else:  # 45 degrees, then straight
                    kx = ax + gx
                    ky = ay + gy
                if half == 0:
                    segments[at, 0, 0] = ax
                    segments[at, 0, 1] = ay
                    segments[at, 1, 0] = kx
                    segments[at, 1, 1] = ky
                else:
                    segments[at, 0, 0] = kx
                    segments[at, 0, 1] = ky
                    segments[at, 1, 0] = ends[j, 0]
                    segments[at, 1, 1] = ends[j, 1]
                at += 1
    return segments, direct[:nd], bent0[:n0], bent1[:n1]


@_jit
def _pick(g, heuristic, closed):
    """The open node of least g + heuristic (the lowest index among equals), -1 when no open
    node has a finite one: `np.argmin(np.where(closed, inf, g + heuristic))`."""
    best = np.inf
    pick = -1
    for i in range(g.shape[0]):
        if closed[i]:
            continue
        f = g[i] + heuristic[i]
        if f < best:
            best = f
            pick = i
    return pick


@_jit
def _targets(nodes, v, base, g, closed):
    """The open nodes whose cost through node v (`base` + octilinear distance from v) is
    below their g, and those costs: `search._octilinear_to` and its comparison, per node."""
    n = nodes.shape[0]
    out = np.empty(n, dtype=np.int64)
    cost = np.empty(n, dtype=np.float64)
    vx = nodes[v, 0]
    vy = nodes[v, 1]
    k = 0
    for i in range(n):
        if closed[i]:
            continue
        dx = float(abs(nodes[i, 0] - vx))
        dy = float(abs(nodes[i, 1] - vy))
        c = base + (max(dx, dy) + (_ROOT2 - 1) * min(dx, dy))
        if c < g[i]:
            out[k] = i
            cost[k] = c
            k += 1
    return out[:k], cost[:k]

"""The compiled work of the search's expansions (`pcbdata.router.search_kernel`) gives the numpy
form's answers: the node it expands next, the nodes whose cost it lowers, the ray screen's
verdicts and missing bounds, and the link batch's segments, on many random nodes; whole plans
both ways are in tests/env/test_negotiated.py."""
from __future__ import annotations

import numpy as np
import pytest

from pcbdata.router import clearance_kernel
from pcbdata.router.search import _LinkBatch, _pick, _Search, _targets

needs_numba = pytest.mark.skipif(clearance_kernel.numba is None,
                                 reason="numba is not installed (scripts/setup.sh installs it)")


class _Nodes(_Search):
    """A search's node table without a board: nodes, rows and ray bounds given."""

    def __init__(self, nodes: np.ndarray, free: np.ndarray):
        self.nodes = nodes
        self.rows = np.arange(len(nodes)) * 3 % len(nodes)  # rows need not be the order
        self.free = free
        self.filled: list[np.ndarray] = []
        self.compiled = clearance_kernel.enabled()

    def _fill(self, keys):
        self.filled.append(keys)
        self.free[keys[:, 0], keys[:, 1]] = 1e6 * (keys[:, 0] % 7)


def _case(seed: int):
    rng = np.random.default_rng(seed)
    n = 400
    nodes = rng.integers(-5_000_000, 5_000_000, (n, 2))
    nodes[: n // 4, 1] = nodes[0, 1]  # on one line with node 0 (straight links)
    diag = rng.integers(-3_000_000, 3_000_000, n // 4)
    nodes[n // 4: n // 2] = nodes[0] + np.stack([diag, diag * rng.choice([-1, 1])], axis=1)
    nodes[n // 2] = nodes[0]  # a zero-length link
    free = rng.choice([0.0, 5e5, 2e6, 8e6, np.inf], (n, 8))
    return rng, nodes, free


@needs_numba
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_screen_and_the_link_batch_agree_with_the_numpy_form(seed, monkeypatch):
    rng, nodes, free = _case(seed)
    for v in (0, 7, 123):
        targets = np.sort(rng.choice(np.arange(1, len(nodes)), 300, replace=False))
        answers = []
        for off in ("1", "0"):
            monkeypatch.setenv("PCBDATA_NO_NUMBA", off)
            search = _Nodes(nodes, free.copy())
            maybe = search._screen(v, targets)
            batch = _LinkBatch(nodes[v], nodes[targets], maybe, search.compiled)
            batch.judge(np.arange(len(batch.segments)) % 3 == 0)
            answers.append((maybe, batch.segments, batch.direct, *batch.bent, batch.clear))
        for numpy_form, compiled in zip(*answers):
            assert numpy_form.dtype == compiled.dtype or numpy_form.size == 0
            np.testing.assert_array_equal(numpy_form, compiled)
        assert answers[0][0].any() and not answers[0][0].all()  # the screen rules some out


@needs_numba
def test_unknown_ray_bounds_are_filled_once_before_the_verdict(monkeypatch):
    rng, nodes, free = _case(3)
    free[rng.random(free.shape) < 0.3] = np.nan
    targets = np.arange(1, 200)
    verdicts, fills = [], []
    for off in ("1", "0"):
        monkeypatch.setenv("PCBDATA_NO_NUMBA", off)
        search = _Nodes(nodes, free.copy())
        verdicts.append(search._screen(0, targets))
        fills.append(search.filled)
    np.testing.assert_array_equal(*verdicts)
    assert len(fills[0]) == len(fills[1]) == 1  # one fill of every missing bound, sorted
    np.testing.assert_array_equal(*[f[0] for f in fills])


@needs_numba
@pytest.mark.parametrize("seed", [0, 1])
def test_the_next_node_and_the_lowered_costs_agree_with_the_numpy_form(seed):
    rng, nodes, _ = _case(seed)
    n = len(nodes)
    g = np.where(rng.random(n) < 0.5, np.inf, rng.uniform(0, 3e7, n))
    g[rng.choice(n, 20)] = 1e7  # ties: the lowest index wins
    heuristic = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0, 1e7, n))
    closed = rng.random(n) < 0.3
    assert _pick(g, heuristic, closed, True) == _pick(g, heuristic, closed, False) >= 0
    assert _pick(g, heuristic, np.ones(n, bool), True) == -1
    assert _pick(np.full(n, np.inf), heuristic, closed, False) == -1
    for v in (0, 5, n // 2):
        g[v] = 1e6  # an expanded node has a cost
        compiled = _targets(nodes, v, g, closed, True)
        numpy_form = _targets(nodes, v, g, closed, False)
        assert len(numpy_form[0]) > 0
        for a, b in zip(compiled, numpy_form):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)

"""The searches' corner nodes worked out from an earlier board state (`pcbdata.router.corners`)
are those of a fresh pass, along a sequence of copper laid and taken up as a planner does; and
the router's sorted items and prepared shapes, kept from one board to the next, are those of a
fresh sort."""
from __future__ import annotations

import random
from dataclasses import replace

import numpy as np
import pytest

from pcbdata.router import corners
from pcbdata.router.corners import corner_nodes, unique_points
from pcbdata.router.geometry import BoardGeometry, CopperItem, item_sort_key
from pcbdata.router.walkaround import WalkaroundRouter

MM = 1_000_000
LAYERS = ("F.Cu", "B.Cu")
NETS = ("A", "B", "C", "D", "")


def _square(x: int, y: int, half: int) -> tuple:
    return ((x - half, y - half), (x + half, y - half), (x + half, y + half), (x - half, y + half))


def _busy_board(rng: random.Random) -> tuple[BoardGeometry, list[CopperItem]]:
    """A 20 x 20 mm two-layer board with pads of five nets (one of them no net, an obstacle to
    all) and a pool of tracks and vias between them to lay and take up."""
    outline = (((0, 0), (20 * MM, 0), (20 * MM, 20 * MM), (0, 20 * MM)),)
    pads = []
    for i in range(36):
        x, y = (2 + 3 * (i % 6)) * MM, (2 + 3 * (i // 6)) * MM
        layers = LAYERS if i % 3 == 0 else (LAYERS[i % 2],)
        pads.append(CopperItem("pad", NETS[i % 5], layers, _square(x, y, 300_000),
                               clearance=200_000))
    pool = []
    for _ in range(60):
        a, b = rng.sample(pads, 2)
        start, end = a.polygon[0], b.polygon[2]
        pool.append(CopperItem("track", a.net, (rng.choice(LAYERS),), start=start, end=end,
                               width=rng.choice((150_000, 250_000)), clearance=150_000))
    for _ in range(10):
        at = (rng.randrange(1, 19) * MM, rng.randrange(1, 19) * MM)
        pool.append(CopperItem("via", rng.choice(NETS[:4]), LAYERS, start=at, end=at,
                               width=600_000, clearance=200_000))
    board = BoardGeometry(outline=outline, copper=tuple(pads), edge_clearance=250_000)
    return board, pool


def _fresh_corners(board: BoardGeometry, net: str, layer: str, width: int, clearance: int):
    router = WalkaroundRouter(board)  # memory of its own: nothing to work from
    return corner_nodes(router, router._rules(net, layer, width, clearance))


@pytest.mark.parametrize("seed", [1, 2])
def test_corners_from_an_earlier_state_are_a_fresh_passes(seed):
    rng = random.Random(seed)
    board, pool = _busy_board(rng)
    router = WalkaroundRouter(board)
    laid: list[CopperItem] = []
    derived = 0
    original = corners._derived

    def counted(*args):
        nonlocal derived
        derived += 1
        return original(*args)

    corners._derived = counted
    try:
        for _ in range(40):
            if laid and rng.random() < 0.35:  # take up copper: corners it blocked come back
                for _ in range(rng.randint(1, 3)):
                    if laid:
                        laid.pop(rng.randrange(len(laid)))
            else:
                laid.extend(rng.sample(pool, rng.randint(1, 3)))
            state = replace(board, copper=board.copper + tuple(laid))
            router.update(state)
            for net in rng.sample(NETS[:4], 2):
                layer = rng.choice(LAYERS)
                width, clearance = rng.choice(((200_000, 200_000), (600_000, 200_000)))
                got = corner_nodes(router, router._rules(net, layer, width, clearance))
                want = _fresh_corners(state, net, layer, width, clearance)
                assert np.array_equal(got, want)
    finally:
        corners._derived = original
    assert derived > 20  # most states were worked out from an earlier one


def test_unique_points_is_numpys_unique_rows():
    rng = np.random.default_rng(0)
    for points in (rng.integers(-5, 5, (200, 2)), rng.integers(-10**9, 10**9, (500, 2)),
                   np.array([[3, -1], [3, -1], [-2, 7]]), np.empty((0, 2), np.int64),
                   np.array([[-2**40, 0], [2**40, 5], [0, 2**40]])):  # too wide: rows sorted
        got = unique_points(points.astype(float))
        assert got.dtype == np.int64
        assert np.array_equal(got, np.unique(points.astype(np.int64).reshape(-1, 2), axis=0))


def test_the_routers_sorted_items_follow_the_board():
    rng = random.Random(3)
    board, pool = _busy_board(rng)
    router = WalkaroundRouter(board)
    current = list(board.copper)
    for _ in range(80):
        move = rng.random()
        if move < 0.3 and current:
            current.pop(rng.randrange(len(current)))
        elif move < 0.8:
            current.append(rng.choice(pool))
        else:
            current.append(rng.choice(current))  # an item twice (one via of two wires)
        rng.shuffle(current)
        router.update(replace(board, copper=tuple(current)))
        assert router._sorted is not None
        assert router._sorted[0] == sorted(current, key=item_sort_key)
        assert set(router._cache) == set(current)  # prepared shapes of this board's items

"""Proofs that no path exists (`_Rules.free_parts`, `_Rules.separated`, the layered search's
`_separated`): true only where certain, and a search that asks for them
(`WalkaroundRouter.prove_separation`) gives the same answers, stopping early where none exists."""
from __future__ import annotations

import pytest
import shapely

from pcbdata.router import layered, search
from pcbdata.router.geometry import BoardGeometry
from pcbdata.router.requests import RouteRequest
from pcbdata.router.walkaround import WalkaroundRouter
from tests.router.test_layered import LAYERS, MM, OUTLINE, assert_legal, rect, request, walled_board


def _rules(router: WalkaroundRouter, layer: str):
    return router._rules("A", layer, 250_000, 200_000)


def test_a_wall_from_edge_to_edge_separates_and_a_gate_does_not():
    router = WalkaroundRouter(walled_board())
    start, goal = (5 * MM, 10 * MM), (25 * MM, 10 * MM)
    assert _rules(router, "F.Cu").separated(router._region, start, goal)  # wall edge to edge
    assert not _rules(router, "B.Cu").separated(router._region, start, goal)  # a gate
    open_board = WalkaroundRouter(BoardGeometry(OUTLINE, (), 300_000))
    assert not _rules(open_board, "F.Cu").separated(open_board._region, start, goal)


def test_an_end_within_a_keep_out_is_doubt_not_proof():
    router = WalkaroundRouter(walled_board())
    in_wall = (15 * MM, 10 * MM)
    assert not _rules(router, "F.Cu").separated(router._region, (5 * MM, 10 * MM), in_wall)


def test_the_free_parts_hold_every_clear_path():
    """The parts are drawn a little larger than the free space: every point of a path the
    router finds lies in the part that holds its start."""
    board = walled_board()
    router = WalkaroundRouter(board)
    result = router.route(RouteRequest("A", "B.Cu", (5 * MM, 10 * MM), (25 * MM, 10 * MM),
                                       250_000, 200_000))
    assert result.path is not None
    parts = _rules(router, "B.Cu").free_parts(router._region)
    holding = [p for p in parts if p.covers(shapely.Point(result.path[0]))]
    assert len(holding) == 1
    assert holding[0].covers(shapely.LineString(result.path))


@pytest.fixture
def ask_at_once(monkeypatch):
    """Searches ask for the proof at their first expansion."""
    monkeypatch.setattr(search, "SEPARATION_AFTER", 0)
    monkeypatch.setattr(layered, "SEPARATION_AFTER", 0)


def test_a_walkaround_search_stops_at_a_proof_and_finds_the_same_paths(ask_at_once):
    board = walled_board()
    proving = WalkaroundRouter(board, prove_separation=True)
    plain = WalkaroundRouter(board)
    walled = RouteRequest("A", "F.Cu", (5 * MM, 10 * MM), (25 * MM, 10 * MM), 250_000, 200_000)
    gated = RouteRequest("A", "B.Cu", (5 * MM, 10 * MM), (25 * MM, 10 * MM), 250_000, 200_000)
    proven = proving.route(walled)
    assert proven.path is None and "separate parts of the free space" in proven.reason
    assert proven.stats["expanded"] == 0
    searched = plain.route(walled)
    assert searched.path is None and searched.stats["expanded"] > 0
    assert proving.route(gated).path == plain.route(gated).path is not None


def test_a_layered_search_stops_at_a_proof_and_finds_the_same_ways(ask_at_once):
    closed = BoardGeometry(OUTLINE, (rect("GND", LAYERS, 14, 0, 16, 30),), 300_000)
    proven = WalkaroundRouter(closed, prove_separation=True).route_layers(request())
    assert proven.legs is None and "joins no part" in proven.reason
    assert proven.stats["expanded"] == 0
    assert WalkaroundRouter(closed).route_layers(request()).legs is None
    board = walled_board()  # F.Cu walled, B.Cu gated: a way through two vias
    found = WalkaroundRouter(board, prove_separation=True).route_layers(request())
    plain = WalkaroundRouter(board).route_layers(request())
    assert found.legs is not None and (found.legs, found.vias) == (plain.legs, plain.vias)
    assert_legal(board, found.legs, found.vias, request())


def test_vias_join_the_parts_of_different_layers(ask_at_once):
    """Start on F.Cu left of its wall, goal on B.Cu right of it (the wall on F.Cu only): F.Cu
    alone separates them, a via spot of the start's ring joins F.Cu's part to B.Cu's, and the
    way is the one found without the proof."""
    board = BoardGeometry(OUTLINE, (rect("GND", ("F.Cu",), 14, 0, 16, 30),), 300_000)
    req = request(goal_layers=("B.Cu",))
    router = WalkaroundRouter(board, prove_separation=True)
    assert router._rules("A", "F.Cu", 250_000, 200_000).separated(router._region, req.start,
                                                                 req.goal)
    found = router.route_layers(req)
    plain = WalkaroundRouter(board).route_layers(req)
    assert found.legs is not None and len(found.vias) >= 1
    assert (found.legs, found.vias) == (plain.legs, plain.vias)
    assert_legal(board, found.legs, found.vias, req)


def _busy_states(seed: int):
    """A busy board with a ring of no-net copper round (9.5, 9.5) mm on both layers (the
    points inside are boxed in), along copper laid and taken up: per state the router, and
    points to pair (pads' centres, points anywhere, points inside the ring)."""
    import random
    from dataclasses import replace

    import numpy as np

    from tests.router.test_corners import LAYERS as TWO
    from tests.router.test_corners import _busy_board

    rng = random.Random(seed)
    board, pool = _busy_board(rng)
    ring = tuple(rect("", TWO, *box) for box in (
        (8.0, 8.0, 11.0, 8.4), (8.0, 10.6, 11.0, 11.0), (8.0, 8.0, 8.4, 11.0),
        (10.6, 8.0, 11.0, 11.0)))
    board = replace(board, copper=board.copper + ring)
    router = WalkaroundRouter(board)
    centres = [tuple(int(c) for c in np.mean(p.polygon, axis=0)) for p in board.copper
               if p.kind == "pad"]
    anywhere = [(rng.randrange(1, 19) * MM, rng.randrange(1, 19) * MM) for _ in range(20)]
    anywhere += [(9_400_000, 9_500_000), (9_600_000, 9_500_000)] * 4  # inside the ring
    laid: list = []
    for _ in range(6):
        laid.extend(rng.sample(pool, 8))
        if rng.random() < 0.3:
            laid = laid[: len(laid) // 2]
        router.update(replace(board, copper=board.copper + tuple(laid)))
        yield rng, router, centres + anywhere


@pytest.mark.parametrize("seed", [1, 2])
def test_the_nearby_proof_answers_as_the_whole_layers_where_it_answers(seed):
    """On a busy board, along copper laid and taken up: for pairs of points (pads' centres,
    boxed in or not, and points anywhere), `separated` with its nearby proof gives the whole
    layer's answer, and the nearby proof settles pairs both ways."""
    import numpy as np

    from pcbdata.router.clearance import parts_apart
    from tests.router.test_corners import LAYERS as TWO
    from tests.router.test_corners import NETS

    settled: list[bool] = []
    for rng, router, points in _busy_states(seed):
        for net in rng.sample(NETS[:4], 2):
            rules = router._rules(net, rng.choice(TWO), rng.choice((150_000, 600_000)), 200_000)
            whole = rules.free_parts(router._region)
            for a, b in rng.sample([(p, q) for p in points for q in points if p != q], 25):
                want = parts_apart([whole], np.empty((0, 2)), a, [0], b, [0])
                nearby = rules._apart_nearby(router._region, a, b)
                if nearby is not None:
                    settled.append(nearby)
                    assert nearby == want, (a, b)
                assert rules.separated(router._region, a, b) == want
    assert settled.count(True) >= 5 and settled.count(False) >= 3  # it answers, both ways


@pytest.mark.parametrize("seed", [1, 2])
def test_the_nearby_proof_over_layers_answers_as_the_whole_layers(seed):
    """The layered search's proof (`apart_nearby` over both layers, parts joined through via
    spots) on the same states: where it answers, `parts_apart` over the whole layers gives
    the same answer, for ends on one layer or both, with spots about the board and inside
    the ring (which join the ring's insides across layers, still boxed in)."""
    import numpy as np

    from pcbdata.router.clearance import apart_nearby, parts_apart
    from tests.router.test_corners import LAYERS as TWO
    from tests.router.test_corners import NETS

    settled: list[bool] = []
    for rng, router, points in _busy_states(seed):
        spots = np.array([(rng.randrange(1, 39) * MM // 2, rng.randrange(1, 39) * MM // 2)
                          for _ in range(60)] + [(9_500_000, 9_300_000)], dtype=np.int64)
        for net in rng.sample(NETS[:4], 2):
            width = rng.choice((150_000, 600_000))
            rules = [router._rules(net, lay, width, 200_000) for lay in TWO]
            whole = [r.free_parts(router._region) for r in rules]
            for a, b in rng.sample([(p, q) for p in points for q in points if p != q], 25):
                a_layers, b_layers = rng.choice(([0], [1], [0, 1])), rng.choice(([0], [1], [0, 1]))
                want = parts_apart(whole, spots, a, a_layers, b, b_layers)
                nearby = apart_nearby(rules, router._region, spots, a, a_layers, b, b_layers)
                if nearby is not None:
                    settled.append(nearby)
                    assert nearby == want, (a, a_layers, b, b_layers)
    assert settled.count(True) >= 5 and settled.count(False) >= 3  # it answers, both ways


def test_the_nearby_proof_follows_vias_out_of_a_boxed_in_part():
    """A ring on F.Cu only round (10, 10) mm with a via spot inside it: the point inside is
    joined through the spot to B.Cu's open space, so it is not apart from a far point on
    B.Cu, and the window cannot settle that (None); a ring on both layers round (20, 20)
    with a spot inside is boxed in on both: the window settles it both ways. In open space
    a point near enough is joined inside the window (settled); on another layer with no spot
    it is apart, which only the whole layers show."""
    import numpy as np

    from pcbdata.router.clearance import apart_nearby, parts_apart

    walls = ((-2.0, -2.0, 2.0, -1.6), (-2.0, 1.6, 2.0, 2.0), (-2.0, -2.0, -1.6, 2.0),
             (1.6, -2.0, 2.0, 2.0))
    board = BoardGeometry(OUTLINE, tuple(
        rect("GND", layers, cx + x0, cy + y0, cx + x1, cy + y1)
        for layers, cx, cy in ((("F.Cu",), 10, 10), (LAYERS, 20, 20))
        for x0, y0, x1, y1 in walls), 300_000)
    router = WalkaroundRouter(board)
    rules = [router._rules("A", lay, 250_000, 200_000) for lay in LAYERS]
    whole = [r.free_parts(router._region) for r in rules]
    spots = np.array([(10 * MM, 9_500_000), (20 * MM, 19_500_000)], dtype=np.int64)
    far, in_f, in_both = (25 * MM, 5 * MM), (10 * MM, 10 * MM), (20 * MM, 20 * MM)
    cases = [  # (a, a_layers, b, b_layers, spots, the answer, whether the window settles it)
        (in_f, [0], far, [1], spots, False, False),
        (in_f, [0], far, [1], spots[:0], True, True),
        (in_both, [0], (20_500_000, 20 * MM), [1], spots, False, True),
        (in_both, [0], (20_500_000, 20 * MM), [1], spots[:0], True, True),
        (in_both, [1], far, [0, 1], spots, True, True),
        # open space, the other point inside the window: joined there, so joined
        ((5 * MM, 5 * MM), [0], (6 * MM, 5 * MM), [0], spots[:0], False, True),
        ((5 * MM, 5 * MM), [1], (6 * MM, 5 * MM), [0], spots[:0], True, False),
    ]
    for a, a_layers, b, b_layers, these, answer, settles in cases:
        assert parts_apart(whole, these, a, a_layers, b, b_layers) == answer
        nearby = apart_nearby(rules, router._region, these, a, a_layers, b, b_layers)
        assert nearby == (answer if settles else None), (a, b, len(these))

"""The layered search (`pcbdata.router.layered`): vias as moves of the search, over every
layer at once; ways checked against exact shapes independently of the router."""
from __future__ import annotations

import shapely

from pcbdata.router.geometry import BoardGeometry, CopperItem, copper_core
from pcbdata.router.layered import LayeredRequest
from pcbdata.router.walkaround import WalkaroundRouter

MM = 1_000_000
LAYERS = ("F.Cu", "B.Cu")
CLEARANCE = 200_000
OUTLINE = (((0, 0), (30 * MM, 0), (30 * MM, 30 * MM), (0, 30 * MM)),)


def rect(net: str, layers, x0: float, y0: float, x1: float, y1: float) -> CopperItem:
    ring = ((round(x0 * MM), round(y0 * MM)), (round(x1 * MM), round(y0 * MM)),
            (round(x1 * MM), round(y1 * MM)), (round(x0 * MM), round(y1 * MM)))
    return CopperItem("zone", net, tuple(layers), polygon=ring, clearance=CLEARANCE)


def walled_board() -> BoardGeometry:
    """A wall across the whole board on F.Cu (edge to edge); on B.Cu a wall with one gate."""
    return BoardGeometry(OUTLINE, (
        rect("GND", ("F.Cu",), 14, 0, 16, 30),
        rect("GND", ("B.Cu",), 14, 0, 16, 20), rect("GND", ("B.Cu",), 14, 22, 16, 30),
        rect("A", ("F.Cu",), 4.8, 9.8, 5.2, 10.2), rect("A", ("F.Cu",), 24.8, 9.8, 25.2, 10.2),
    ), edge_clearance=300_000)


def request(**changes) -> LayeredRequest:
    base = dict(net="A", start=(5 * MM, 10 * MM), start_layers=("F.Cu",), goal=(25 * MM, 10 * MM),
                goal_layers=("F.Cu",), width=250_000, clearance=CLEARANCE, via_diameter=600_000,
                layers=LAYERS, reach=(200_000, 200_000))
    return LayeredRequest(**{**base, **changes})


def assert_legal(board: BoardGeometry, legs, vias, req: LayeredRequest) -> None:
    items = [CopperItem("track", req.net, (layer,), start=a, end=b, width=req.width,
                        clearance=req.clearance)
             for layer, path in legs for a, b in zip(path, path[1:])]
    items += [CopperItem("via", req.net, req.layers, start=v, end=v, width=req.via_diameter,
                         clearance=req.clearance) for v in vias]
    region = shapely.Polygon(board.outline[0])
    for a in items:
        core_a, ra = copper_core(a)
        assert region.buffer(-(ra + board.edge_clearance) + 1).covers(core_a)
        for b in board.copper:
            if b.net == a.net or not set(a.layers) & set(b.layers):
                continue
            core_b, rb = copper_core(b)
            gap = shapely.distance(core_a, core_b) - ra - rb
            assert gap >= max(a.clearance, b.clearance) - 1e-3, (a, b, gap)


def test_a_way_through_the_other_layer_takes_two_vias_and_keeps_clearance():
    board = walled_board()
    router = WalkaroundRouter(board)
    req = request()
    assert router.route(_flat(req)).path is None  # no way on F.Cu alone
    result = router.route_layers(req)
    assert result.legs is not None and len(result.vias) == 2
    assert [layer for layer, _ in result.legs] == ["F.Cu", "B.Cu", "F.Cu"]
    assert result.legs[0][1][0] == req.start and result.legs[-1][1][-1] == req.goal
    for (_, path), via in zip(result.legs, result.vias):
        assert path[-1] == via
    middle = result.legs[1][1]
    assert any(20 * MM < y < 22 * MM for _, y in middle)  # through the gate
    assert_legal(board, result.legs, result.vias, req)
    again = WalkaroundRouter(board).route_layers(req)  # deterministic
    assert (again.legs, again.vias) == (result.legs, result.vias)


def test_ends_on_different_layers_take_one_via():
    board = BoardGeometry(OUTLINE, walled_board().copper[:3], 300_000)
    req = request(goal=(8 * MM, 25 * MM), goal_layers=("B.Cu",))
    result = WalkaroundRouter(board).route_layers(req)
    assert result.legs is not None and len(result.vias) == 1
    assert result.legs[0][0] == "F.Cu" and result.legs[-1][0] == "B.Cu"
    assert_legal(board, result.legs, result.vias, req)


def test_no_way_anywhere_is_a_reason():
    closed = BoardGeometry(OUTLINE, (rect("GND", LAYERS, 14, 0, 16, 30),), 300_000)
    result = WalkaroundRouter(closed).route_layers(request())
    assert result.legs is None and result.reason


def _flat(req: LayeredRequest):
    from pcbdata.router.requests import RouteRequest

    return RouteRequest(req.net, "F.Cu", req.start, req.goal, req.width, req.clearance)


def gated_board() -> tuple[BoardGeometry, CopperItem]:
    """F.Cu only: a wall with a near gate (y 9-11) and a far one (y 17-19, inside the search's
    first window); a track of net X fills the near gate (soft copper in the tests)."""
    copper = (rect("GND", ("F.Cu",), 14, 0, 16, 9), rect("GND", ("F.Cu",), 14, 11, 16, 17),
              rect("GND", ("F.Cu",), 14, 19, 16, 30), rect("GND", ("B.Cu",), 0, 0, 30, 30))
    track = CopperItem("track", "X", ("F.Cu",), start=(13 * MM, 10 * MM),
                       end=(17 * MM, 10 * MM), width=1_200_000, clearance=CLEARANCE)
    return BoardGeometry(OUTLINE, copper, 300_000), track


def test_soft_copper_is_crossed_at_its_price_or_gone_round():
    from pcbdata.router.soft import SoftCopper

    board, track = gated_board()
    with_track = BoardGeometry(board.outline, board.copper + (track,), board.edge_clearance)
    req = request(layers=("F.Cu",))
    near = WalkaroundRouter(with_track).route_layers(req)  # hard: the far gate only
    assert near.legs is not None and max(y for _, y in near.legs[0][1]) > 16 * MM
    router = WalkaroundRouter(board)
    cheap = router.route_layers(req, SoftCopper((track,), (7,), {7: 1_000_000}))
    path = cheap.legs[0][1]
    assert max(y for _, y in path) < 12 * MM  # through the near gate, across the track
    assert_legal(board, cheap.legs, cheap.vias, req)
    dear = router.route_layers(req, SoftCopper((track,), (7,), {7: 100_000_000}))
    assert max(y for _, y in dear.legs[0][1]) > 16 * MM  # the detour costs less
    assert_legal(with_track, dear.legs, dear.vias, req)


def test_holes_keep_via_spots_off_drilled_copper_the_board_lacks():
    """A request's `holes` (its net's drilled copper that the router's board does not hold,
    as the rip-up search's board lacks the net's planned vias) keep every via off them: no
    via of the way overlaps one, but a via on a hole's very point (the same via) may stand; holes
    that keep no spot off leave the search as it is, its remembered answer included."""
    import math

    from pcbdata.router.layered import kept_off

    board = walled_board()
    free = WalkaroundRouter(board).route_layers(request())
    assert free.legs is not None and len(free.vias) == 2
    first = free.vias[0]
    hole = ((first[0] + 300_000, first[1]), 600_000)  # overlaps the way's first via
    req = request(holes=(hole,))
    router = WalkaroundRouter(board)
    assert kept_off(router, req)
    kept = router.route_layers(req)
    assert kept.legs is not None and kept.vias != free.vias
    for via in kept.vias:
        gap = math.dist(via, hole[0])
        assert gap == 0 or gap >= (hole[1] + req.via_diameter) / 2
    assert_legal(board, kept.legs, kept.vias, req)
    assert kept_off(router, request()) == ()  # no holes: the search as before
    far = request(holes=(((27 * MM, 27 * MM), 600_000),))  # keeps no spot the way could use off
    assert kept_off(router, far) == ()
    assert router.route_layers(far) is router.route_layers(request())  # one remembered answer
    same = router.route_layers(request(holes=((first, 600_000),)))  # on the via's very point
    assert first in same.vias


def test_priced_links_reuse_the_expansions_verdicts_with_the_same_answers(monkeypatch):
    """A rip-up search prices only the link variants its expansion found clear of hard
    copper (`_Layered._link_prices` with `clear`): on a busy board, with soft copper of several
    owners, its ways, vias and counted work are those of pricing every variant from scratch."""
    import numpy as np

    from pcbdata.router import layered
    from pcbdata.router.soft import SoftCopper

    rng = np.random.default_rng(3)
    hard, soft = [], []
    for k in range(70):
        x, y = rng.uniform(3, 27, 2)
        dx, dy = rng.uniform(-4, 4, 2)
        item = CopperItem("track", "GND" if k % 2 else f"S{k % 7}", (LAYERS[k % 4 // 2],),
                          start=(round(x * MM), round(y * MM)),
                          end=(round((x + dx) * MM), round((y + dy) * MM)),
                          width=300_000, clearance=CLEARANCE)
        (hard if k % 3 == 0 else soft).append(item)
    board = BoardGeometry(OUTLINE, (*walled_board().copper[3:], *hard), 300_000)
    prices = SoftCopper(tuple(soft), tuple(int(i.net[1:]) if i.net != "GND" else 9
                                           for i in soft),
                        {o: 3_000_000.0 + o for o in (*range(7), 9)})
    calls = {"with": 0}
    original = layered._Layered._link_prices

    def counting(self, k, graph, i, targets, clear=None):
        calls["with"] += clear is not None and bool((~clear).any())
        return original(self, k, graph, i, targets, clear)

    monkeypatch.setattr(layered._Layered, "_link_prices", counting)
    req = request()
    reused = WalkaroundRouter(board).route_layers(req, prices)
    assert reused.legs is not None and calls["with"] > 0  # some variants were blocked
    monkeypatch.setattr(layered._Layered, "_link_prices",
                        lambda self, k, graph, i, targets, clear=None:
                        original(self, k, graph, i, targets))
    scratch = WalkaroundRouter(board).route_layers(req, prices)
    assert (reused.legs, reused.vias, reused.stats) == (scratch.legs, scratch.vias,
                                                        scratch.stats)
    assert_legal(board, reused.legs, reused.vias, req)

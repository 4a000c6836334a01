"""The walkaround router (`pcbdata.router.walkaround`): octilinear paths that keep the rules'
clearance, checked against an independent exact model of the copper (shapely distances), plus
D2 boards routed net by net (`pcbdata/testing/d2_routes.py`)."""
from __future__ import annotations

import math

import pytest
import shapely

from pcbdata.router.geometry import (
    BoardGeometry,
    CopperItem,
    arc_polyline,
    circle_polygon,
    is_octilinear,
    one_bend_paths,
    simplify_path,
)
from pcbdata.router.requests import RouteRequest, mark_obstacles_path
from pcbdata.router.walkaround import WalkaroundRouter

MM = 1_000_000
WIDTH, CLEARANCE, EDGE = 200_000, 200_000, 500_000
BOARD = ((0, 0), (20 * MM, 0), (20 * MM, 20 * MM), (0, 20 * MM))
# KiCad passes a gap equal to the clearance; float distances may put such a gap a hair below.
FLOAT_SLACK = 1e-3  # nm


def pad(net: str, x: float, y: float, size: float = 1.0, layers=("F.Cu",),
        clearance: int = CLEARANCE) -> CopperItem:
    """A square pad of `size` mm centred at (x, y) mm."""
    h = round(size * MM / 2)
    cx, cy = round(x * MM), round(y * MM)
    ring = ((cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h))
    return CopperItem("pad", net, tuple(layers), polygon=ring, clearance=clearance)


def wall(net: str, x1, y1, x2, y2, width: float = 0.4) -> CopperItem:
    return CopperItem("track", net, ("F.Cu",), start=(round(x1 * MM), round(y1 * MM)),
                      end=(round(x2 * MM), round(y2 * MM)), width=round(width * MM),
                      clearance=CLEARANCE)


def board(*items: CopperItem, outline=(BOARD,)) -> BoardGeometry:
    return BoardGeometry(outline=outline, copper=tuple(items), edge_clearance=EDGE)


def request(net: str, start, goal, layer="F.Cu", width=WIDTH, clearance=CLEARANCE):
    return RouteRequest(net=net, layer=layer, start=(round(start[0] * MM), round(start[1] * MM)),
                        goal=(round(goal[0] * MM), round(goal[1] * MM)), width=width,
                        clearance=clearance)


def exact_gaps(geometry: BoardGeometry, req: RouteRequest, path) -> list[float]:
    """Copper-to-copper gap minus the required clearance, for every other-net item on the layer
    and the board edge: all must be >= 0 (KiCad's rule: an equal gap is legal). Exact shapes:
    tracks are capsules, pads polygons."""
    line = shapely.LineString(path) if len(path) > 1 else shapely.Point(path[0])
    out = []
    for item in geometry.copper:
        if item.net == req.net or req.layer not in item.layers:
            continue
        if item.kind == "pad":
            other, radius = shapely.Polygon(item.polygon), 0.0
        elif item.kind == "via":
            other, radius = shapely.Point(item.start), item.width / 2
        else:
            other, radius = shapely.LineString([item.start, item.end]), item.width / 2
        need = max(req.clearance, item.clearance)
        out.append(shapely.distance(line, other) - radius - req.width / 2 - need)
    edge = shapely.Polygon(geometry.outline[0]).exterior
    out.append(shapely.distance(line, edge) - req.width / 2 - geometry.edge_clearance)
    return out


def assert_legal(geometry: BoardGeometry, req: RouteRequest, path) -> None:
    assert path[0] == req.start and path[-1] == req.goal
    assert all(is_octilinear(a, b) for a, b in zip(path, path[1:])), path
    assert all(isinstance(v, int) for p in path for v in p)
    gaps = exact_gaps(geometry, req, path)
    assert min(gaps) >= -FLOAT_SLACK, (path, min(gaps))


# --- octilinear helpers ----------------------------------------------------------------------

def test_one_bend_paths_are_octilinear_and_shortest():
    a, b = (0, 0), (7_000, 3_000)
    paths = one_bend_paths(a, b)
    assert paths == (((0, 0), (4_000, 0), (7_000, 3_000)), ((0, 0), (3_000, 3_000), (7_000, 3_000)))
    for path in paths:
        assert all(is_octilinear(p, q) for p, q in zip(path, path[1:]))
        length = sum(math.dist(p, q) for p, q in zip(path, path[1:]))
        assert length == pytest.approx(4_000 + 3_000 * math.sqrt(2))
    assert one_bend_paths((0, 0), (5, -5)) == (((0, 0), (5, -5)),)
    assert mark_obstacles_path((0, 0), (0, 0)) == ((0, 0),)


def test_simplify_merges_collinear_runs_and_repeats():
    assert simplify_path([(0, 0), (1, 0), (1, 0), (3, 0), (4, 1), (5, 2)]) == \
        ((0, 0), (3, 0), (5, 2))


def test_circle_and_arc_models_err_outwards():
    polygon = shapely.Polygon(circle_polygon(0, 0, 1_200_000))
    assert polygon.contains(shapely.Point(0, 0).buffer(1_200_000, quad_segs=256))
    chords, sagitta = arc_polyline((1_000_000, 0), (0, 1_000_000), (-1_000_000, 0))
    true_arc = [(1_000_000 * math.cos(t), 1_000_000 * math.sin(t))
                for t in (k * math.pi / 500 for k in range(501))]
    gap = max(shapely.distance(shapely.Point(p), shapely.LineString(chords)) for p in true_arc)
    assert 0 < gap <= sagitta + 1


# --- tries, cheapest first -------------------------------------------------------------------

def test_direct_and_two_segment_on_a_clear_board():
    geometry = board(pad("A", 2, 2), pad("A", 12, 2), pad("A", 9, 7))
    router = WalkaroundRouter(geometry)
    straight = router.route(request("A", (2, 2), (12, 2)))
    assert straight.path == ((2 * MM, 2 * MM), (12 * MM, 2 * MM))
    assert straight.stats["method"] == "direct" and straight.reason == ""
    bent = router.route(request("A", (2, 2), (9, 7)))
    assert bent.stats["method"] == "two_segment" and len(bent.path) == 3
    assert_legal(geometry, request("A", (2, 2), (9, 7)), bent.path)


def test_goes_around_another_nets_wall():
    geometry = board(pad("A", 3, 10), pad("A", 17, 10), wall("B", 10, 4, 10, 16, width=1.0),
                     pad("B", 10, 3), pad("B", 10, 17))
    req = request("A", (3, 10), (17, 10))
    result = WalkaroundRouter(geometry).route(req)
    assert result.path is not None, result.reason
    assert result.stats["method"] == "search"
    assert_legal(geometry, req, result.path)
    # Around the wall's end, not through it: the path leaves the straight line by > 6 mm.
    assert max(abs(y - 10 * MM) for _, y in result.path) > 6 * MM


def test_own_net_copper_is_no_obstacle_and_no_net_copper_is():
    own = board(pad("A", 3, 10), pad("A", 17, 10), wall("A", 10, 2, 10, 18))
    assert WalkaroundRouter(own).route(request("A", (3, 10), (17, 10))).stats["method"] == \
        "direct"
    unnamed = board(pad("A", 3, 10), pad("A", 17, 10), wall("", 10, 5, 10, 15))
    req = request("A", (3, 10), (17, 10))
    result = WalkaroundRouter(unnamed).route(req)
    assert result.stats["method"] == "search"
    assert_legal(unnamed, req, result.path)


def test_the_larger_clearance_of_the_two_nets_holds():
    """Item clearance 1 mm (its net class) beats the request's 0.2 mm."""
    obstacle = pad("B", 10, 10.9, size=1.0, clearance=1_000_000)
    geometry = board(pad("A", 3, 10), pad("A", 17, 10), obstacle)
    req = request("A", (3, 10), (17, 10))
    result = WalkaroundRouter(geometry).route(req)
    assert result.path is not None and result.stats["method"] != "direct"
    assert_legal(geometry, req, result.path)
    # The same pad with the request's own clearance is passed straight by.
    loose = board(pad("A", 3, 10), pad("A", 17, 10), pad("B", 10, 10.9, size=1.0))
    assert WalkaroundRouter(loose).route(req).stats["method"] == "direct"


def test_other_layers_do_not_block():
    geometry = board(pad("A", 3, 10), pad("A", 17, 10),
                     CopperItem("track", "B", ("B.Cu",), start=(10 * MM, 0), end=(10 * MM, 20 * MM),
                                width=MM, clearance=CLEARANCE))
    assert WalkaroundRouter(geometry).route(request("A", (3, 10), (17, 10))).path is not None
    blocked = WalkaroundRouter(geometry).route(request("A", (3, 10), (17, 10), layer="B.Cu"))
    assert blocked.path is None and blocked.reason.startswith("no path")


def test_board_edge_keeps_its_clearance():
    geometry = board(pad("A", 1.0, 10), pad("A", 19, 10))
    near_edge = WalkaroundRouter(geometry).route(request("A", (0.3, 10), (19, 10)))
    assert near_edge.path is None and "board edge" in near_edge.reason
    outside = WalkaroundRouter(geometry).route(request("A", (-1, 10), (19, 10)))
    assert outside.path is None and "outside the board" in outside.reason
    # An L-shaped board: the way from one arm to the other turns the inner corner.
    ell = ((0, 0), (20 * MM, 0), (20 * MM, 6 * MM), (6 * MM, 6 * MM), (6 * MM, 20 * MM),
           (0, 20 * MM))
    geometry = board(outline=(ell,))
    req = request("A", (17, 3), (3, 17))
    result = WalkaroundRouter(geometry).route(req)
    assert result.path is not None, result.reason
    line = shapely.LineString(result.path)
    assert shapely.Polygon(ell).contains(line)
    assert shapely.distance(line, shapely.Polygon(ell).exterior) >= WIDTH / 2 + EDGE


def test_enclosed_goal_fails_fast_with_a_reason():
    ring = [wall("B", 8, 8, 12, 8), wall("B", 12, 8, 12, 12), wall("B", 12, 12, 8, 12),
            wall("B", 8, 12, 8, 8)]
    geometry = board(pad("A", 3, 3), pad("A", 10, 10), *ring)
    result = WalkaroundRouter(geometry).route(request("A", (3, 3), (10, 10)))
    assert result.path is None and result.reason.startswith("no path")
    assert result.stats["seconds"] < 1.0


def test_start_inside_another_nets_clearance_is_refused():
    geometry = board(pad("A", 3, 10), pad("B", 3.79, 10), pad("A", 15, 10))
    result = WalkaroundRouter(geometry).route(request("A", (3.0, 10), (15, 10)))
    assert result.path is None and "start" in result.reason and "net 'B'" in result.reason


def test_search_budget_is_a_reason_not_a_hang():
    pillars = [pad("B", x, y, size=0.6) for x in range(4, 17, 2) for y in range(3, 18, 2)]
    geometry = board(pad("A", 2, 2), pad("A", 18, 18), *pillars)
    req = request("A", (2, 2), (18, 18.5))
    tight = WalkaroundRouter(geometry, budget_nodes=2).route(req)
    assert tight.path is None and "search budget" in tight.reason
    free = WalkaroundRouter(geometry).route(req)
    assert free.path is not None, free.reason
    assert_legal(geometry, req, free.path)


def _pillar_maze():
    pillars = [pad("B", x, y, size=0.6) for x in range(4, 17, 2) for y in range(3, 18, 2)]
    return board(pad("A", 2, 2), pad("A", 18, 18), *pillars), request("A", (2, 2), (18, 18.5))


def test_link_check_budget_is_a_reason_too():
    geometry, req = _pillar_maze()
    free = WalkaroundRouter(geometry).route(req)
    assert free.path is not None and free.stats["checks"] > 10
    tight = WalkaroundRouter(geometry, budget_checks=10).route(req)
    assert tight.path is None and "10 link checks" in tight.reason
    assert tight.stats["checks"] >= 10


def test_a_slow_machine_gets_the_same_answer(monkeypatch):
    # The budget counts work, not seconds: a clock that jumps 100 s at every reading (a machine
    # thousands of times slower) changes nothing unless a wall-clock limit is asked for.
    import pcbdata.router.walkaround as walkaround

    geometry, req = _pillar_maze()
    quick = WalkaroundRouter(geometry).route(req)
    ticks = iter(range(0, 10**9, 100))
    monkeypatch.setattr(walkaround.time, "perf_counter", lambda: float(next(ticks)))
    slow = WalkaroundRouter(geometry).route(req)
    assert quick.path is not None and slow.path == quick.path
    assert {k: v for k, v in slow.stats.items() if k != "seconds"} == \
        {k: v for k, v in quick.stats.items() if k != "seconds"}
    limited = WalkaroundRouter(geometry, budget_seconds=150.0).route(req)
    assert limited.path is None and "150 s" in limited.reason


def test_deterministic_and_independent_of_item_order():
    items = [pad("A", 3, 10), pad("A", 17, 12), wall("B", 10, 4, 10, 16), pad("C", 6, 8),
             wall("D", 13, 6, 15, 14), CopperItem("via", "E", ("F.Cu", "B.Cu"),
                                                   start=(7 * MM, 13 * MM), width=600_000,
                                                   clearance=CLEARANCE)]
    req = request("A", (3, 10), (17, 12))
    first = WalkaroundRouter(board(*items)).route(req)
    again = WalkaroundRouter(board(*items)).route(req)
    shuffled = WalkaroundRouter(board(*reversed(items))).route(req)
    assert first.path is not None
    assert first.path == again.path == shuffled.path
    assert_legal(board(*items), req, first.path)


def test_via_fits_checks_every_layer_and_the_edge():
    geometry = board(CopperItem("track", "B", ("B.Cu",), start=(5 * MM, 0), end=(5 * MM, 20 * MM),
                                width=WIDTH, clearance=CLEARANCE))
    router = WalkaroundRouter(geometry)
    assert router.via_fits("A", (10 * MM, 10 * MM), 600_000, CLEARANCE, ("F.Cu", "B.Cu"))
    assert not router.via_fits("A", (5 * MM + 500_000, 10 * MM), 600_000, CLEARANCE,
                               ("F.Cu", "B.Cu"))
    assert router.via_fits("A", (5 * MM + 500_000, 10 * MM), 600_000, CLEARANCE, ("F.Cu",))
    assert not router.via_fits("A", (600_000, 10 * MM), 600_000, CLEARANCE, ("F.Cu",))


def test_a_via_keeps_off_its_own_nets_drilled_copper_but_not_its_surface_pads():
    """Holes keep apart whatever their nets (KiCad's hole_to_hole): a via may not overlap a
    through-hole pad or a via of its own net; on a surface pad of its net it may sit."""
    both = ("F.Cu", "B.Cu")
    via = CopperItem("via", "A", both, start=(14 * MM, 10 * MM), end=(14 * MM, 10 * MM),
                     width=600_000, clearance=CLEARANCE)
    router = WalkaroundRouter(board(pad("A", 6, 10, size=1.6, layers=both),
                                    pad("A", 10, 10, size=1.6), via))
    fits = router.vias_fit("A", [(6 * MM, 10 * MM), (6 * MM + 900_000, 10 * MM),
                                 (6 * MM + 1_500_000, 10 * MM), (10 * MM, 10 * MM),
                                 (14 * MM + 500_000, 10 * MM), (14 * MM + 700_000, 10 * MM)],
                           600_000, CLEARANCE, both)
    assert fits.tolist() == [False, False, True, True, False, True]


def test_a_gap_equal_to_the_clearance_is_legal_and_one_nm_less_is_not():
    """D1-10's geometry: a track leaving a pad runs at exactly the edge clearance from the edge
    and exactly the clearance from the pad of the next cell (KiCad's DRC accepts both)."""
    g, half = 10 * MM, 5 * MM // 2  # pitch; half the track width = half a pad's side
    side = 10 * g + g // 2
    edge = ((0, 0), (side, 0), (side, side), (0, side))

    def d1_pad(net, i, j):
        cx, cy = (4 * i + 3) * g // 4, (4 * j + 3) * g // 4
        ring = ((cx - half, cy - half), (cx + half, cy - half), (cx + half, cy + half),
                (cx - half, cy + half))
        return CopperItem("pad", net, ("F.Cu",), polygon=ring, clearance=g // 2)

    geometry = BoardGeometry(outline=(edge,), copper=(d1_pad("A", 5, 9), d1_pad("A", 0, 9),
                                                      d1_pad("B", 3, 8)), edge_clearance=g // 2)
    req = RouteRequest("A", "F.Cu", (57_500_000, 97_500_000), (7_500_000, 97_500_000), g // 2,
                       g // 2)
    result = WalkaroundRouter(geometry).route(req)
    assert result.path == (req.start, req.goal), result.reason
    assert_legal(geometry, req, result.path)
    assert min(exact_gaps(geometry, req, result.path)) == 0
    router = WalkaroundRouter(geometry)
    for dy in (1, -1):  # 1 nm nearer the edge; 1 nm nearer pad B
        start, goal = (req.start[0], req.start[1] + dy), (req.goal[0], req.goal[1] + dy)
        assert not router.segment_is_clear("A", "F.Cu", start, goal, g // 2, g // 2)


def test_detours_hug_keep_outs_at_exactly_the_clearance():
    """Corner nodes sit at the clearance, not beyond it: a path squeezes between two pads
    whose gap is exactly a track and two clearances wide."""
    gap = WIDTH + 2 * CLEARANCE
    top = pad("B", 10, 9.5)
    low = CopperItem("pad", "C", ("F.Cu",), clearance=CLEARANCE, polygon=tuple(
        (x, y + MM + gap) for x, y in top.polygon))
    geometry = board(pad("A", 3, 3), pad("A", 17, 17), top, low,
                     wall("B", 10, 0.6, 10, 9.5, width=1.0), wall("C", 10, 11.5, 10, 19.4,
                                                                  width=1.0))
    req = request("A", (3, 3), (17, 17))
    result = WalkaroundRouter(geometry).route(req)
    assert result.path is not None, result.reason
    assert_legal(geometry, req, result.path)
    assert min(exact_gaps(geometry, req, result.path)) < 1.0


# --- D2 boards, routed net by net -------------------------------------------------------------

def test_d2_boards_route_legally_and_quickly():
    """Eight D2 test boards, every connection asked of the router (later nets avoid earlier
    paths): no clearance or edge violation in an exact independent check, no call over 1 s, and
    nearly every connection found."""
    from pcbdata.testing.d2_routes import d2_test_boards, route_board, violations

    calls, open_total, connections = [], 0, 0
    for name, b in d2_test_boards(8):
        routed, board_calls, open_connections = route_board(name, b)
        assert violations(routed) == [], name
        calls += board_calls
        open_total += open_connections
        connections += sum(len([p for p in b.pads if p.net == n]) - 1 for n in b.net_names)
    assert max(c.seconds for c in calls) < 1.0
    assert {c.method for c in calls} >= {"direct", "two_segment", "search"}
    assert open_total <= connections // 20, (open_total, connections)

"""push_n_shove's plan (`pcbdata.router.shove`) alone on plain geometry, checked against the
independent exact model of `test_walkaround.py`. In the environment and KiCad:
`tests/env/test_shove_env.py`."""
from __future__ import annotations

import random

from pcbdata.router.geometry import BoardGeometry, CopperItem
from pcbdata.router.shove import path_items, plan
from pcbdata.router.walkaround import WalkaroundRouter
from tests.router.test_walkaround import CLEARANCE, MM, board, exact_gaps, pad, request, wall

# A narrow board: net A must run straight along y = 9 mm between its pads; net B's pads sit on
# the top edge and its track dips down across A's way, so walkaround alone cannot pass.
OUTLINE = ((0, 1_400_000), (20 * MM, 1_400_000), (20 * MM, 10 * MM), (0, 10 * MM))
B_DIP = (wall("B", 8, 2.5, 8, 9, 0.25), wall("B", 8, 9, 12, 9, 0.25),
         wall("B", 12, 9, 12, 2.5, 0.25))


def _board(*extra) -> BoardGeometry:
    return board(pad("A", 2, 9), pad("A", 18, 9), pad("B", 8, 2.5), pad("B", 12, 2.5),
                 *B_DIP, *extra, outline=(OUTLINE,))


def _after(geometry: BoardGeometry, done, req) -> BoardGeometry:
    """The board once the plan is applied."""
    gone = set(done.removed)
    items = [i for i in geometry.copper if i not in gone]
    items += path_items(req.net, req.layer, done.path, req.width, req.clearance)
    for r in done.reroutes:
        items += path_items(r.net, r.layer or req.layer, r.path, r.width, CLEARANCE)
    return BoardGeometry(geometry.outline, tuple(items), geometry.edge_clearance)


def test_walkaround_alone_cannot_pass():
    assert WalkaroundRouter(_board()).route(request("A", (2, 9), (18, 9))).path is None


def test_blocking_tracks_are_taken_up_and_their_net_joined_again_legally():
    geometry, req = _board(), request("A", (2, 9), (18, 9))
    done = plan(WalkaroundRouter(geometry), req)
    assert done.path == ((2 * MM, 9 * MM), (18 * MM, 9 * MM)), done.reason
    assert set(done.removed) == set(B_DIP) and done.moved_nets == ("B",)
    assert [(r.net, r.path[0], r.path[-1]) for r in done.reroutes] == \
        [("B", (8 * MM, 2_500_000), (12 * MM, 2_500_000))]
    final = _after(geometry, done, req)
    assert min(exact_gaps(final, req, done.path)) >= 0
    for r in done.reroutes:
        own = request("B", (8, 2.5), (12, 2.5), width=r.width)
        assert min(exact_gaps(final, own, r.path)) >= 0
    assert done.stats["method"] == "shove" and done.stats["moved_tracks"] == 3


def test_a_track_drawn_twice_is_taken_up_twice():
    """Two identical tracks are two KiCad tracks: the plan removes each (one removal left one
    of them under the new path)."""
    geometry, req = _board(B_DIP[1]), request("A", (2, 9), (18, 9))
    done = plan(WalkaroundRouter(geometry), req)
    assert done.path is not None, done.reason
    assert sorted(done.removed, key=str) == sorted(B_DIP + (B_DIP[1],), key=str)
    assert min(exact_gaps(_after(geometry, done, req), req, done.path)) >= 0


def test_the_plan_does_not_depend_on_item_order():
    geometry, req = _board(), request("A", (2, 9), (18, 9))
    items = list(geometry.copper)
    random.Random(1).shuffle(items)
    shuffled = BoardGeometry(geometry.outline, tuple(items), geometry.edge_clearance)
    assert plan(WalkaroundRouter(shuffled), req) == plan(WalkaroundRouter(geometry), req)


def test_no_shove_when_walkaround_finds_a_path():
    geometry = board(pad("A", 2, 9), pad("A", 18, 9), wall("B", 8, 2, 8, 5))
    done = plan(WalkaroundRouter(geometry), request("A", (2, 9), (18, 9)))
    assert done.path is not None and done.removed == () and done.reroutes == ()
    assert done.stats["shove"] == "not_needed"


def test_pads_are_not_moved():
    geometry = board(pad("A", 2, 9), pad("A", 18, 9), pad("C", 10, 6, size=7.9),
                     outline=(OUTLINE,))
    done = plan(WalkaroundRouter(geometry), request("A", (2, 9), (18, 9)))
    assert done.path is None and "no other net's track to move" in done.reason


def test_a_net_that_cannot_be_joined_again_changes_nothing():
    # B's pads below A's way: once A runs along y = 9, B's two sides are cut apart.
    # A's pads reach the side edges, so nothing passes around A's ends either.
    geometry = board(pad("A", 1, 9), pad("A", 19, 9), pad("B", 10, 9.9, size=0.2),
                     pad("B", 10, 3, size=0.6), wall("B", 10, 3, 10, 9.9, 0.25),
                     outline=(((0, 2 * MM), (20 * MM, 2 * MM), (20 * MM, 10.6 * MM),
                               (0, 10.6 * MM)),))
    done = plan(WalkaroundRouter(geometry), request("A", (1, 9), (19, 9)))
    assert done.path is None and "'B'" in done.reason
    assert done.removed == () and done.reroutes == ()


def _cut_off_b(top_layers: tuple[str, ...]):
    """The board above with B's top pad on `top_layers`, A's request and the via rules."""
    from pcbdata.router.shove import ViaRules

    geometry = board(pad("A", 1, 9), pad("A", 19, 9), pad("B", 10, 9.9, size=0.2),
                     pad("B", 10, 3, size=0.6, layers=top_layers),
                     wall("B", 10, 3, 10, 9.9, 0.25),
                     outline=(((0, 2 * MM), (20 * MM, 2 * MM), (20 * MM, 10.6 * MM),
                               (0, 10.6 * MM)),))
    vias = ViaRules(("F.Cu", "B.Cu"), lambda net: (400_000, 200_000))
    return geometry, request("A", (1, 9), (19, 9)), vias


def test_a_cut_off_net_is_joined_again_through_a_via_when_its_far_end_reaches_another_layer():
    """As above, but B's top pad is a through-hole pad: B hops to B.Cu through one via placed
    on its taken-up track's way (here on its own bottom pad) and runs under A's new path."""
    from pcbdata.router.shove import ViaDrop

    geometry, req, vias = _cut_off_b(top_layers=("F.Cu", "B.Cu"))
    done = plan(WalkaroundRouter(geometry), req, vias=vias)
    assert done.path is not None, done.reason
    assert done.vias == (ViaDrop("B", (10 * MM, 9_900_000), 400_000, 200_000),)
    assert [(r.net, r.layer, r.path[0], r.path[-1]) for r in done.reroutes] == \
        [("B", "B.Cu", (10 * MM, 9_900_000), (10 * MM, 3 * MM))]
    assert done.stats["rejoin_vias"] == 1
    via = CopperItem("via", "B", ("F.Cu", "B.Cu"), start=done.vias[0].at, end=done.vias[0].at,
                     width=400_000, clearance=CLEARANCE)
    final = _after(geometry, done, req)
    final = BoardGeometry(final.outline, final.copper + (via,), final.edge_clearance)
    assert min(exact_gaps(final, req, done.path)) >= 0  # A keeps clear of the via too
    leg = done.reroutes[0]
    under = request("B", (10, 9.9), (10, 3), layer="B.Cu", width=leg.width)
    assert min(exact_gaps(final, under, leg.path)) >= 0
    assert plan(WalkaroundRouter(geometry), req).path is None  # without vias: as before


def test_a_cut_off_net_with_both_ends_on_one_layer_is_joined_again_under_the_new_path():
    """Both of B's pads are surface pads on F.Cu: B goes down through a via near one end, runs
    on B.Cu under A's new path and comes up through a via near the other end."""
    geometry, req, vias = _cut_off_b(top_layers=("F.Cu",))
    done = plan(WalkaroundRouter(geometry), req, vias=vias)
    assert done.path is not None, done.reason
    assert len(done.vias) == 2 and done.stats["rejoin_vias"] == 2
    assert done.stats["rejoins_under"] == 1
    assert {r.layer for r in done.reroutes} >= {"B.Cu"}
    dropped = tuple(CopperItem("via", "B", ("F.Cu", "B.Cu"), start=v.at, end=v.at,
                               width=v.diameter, clearance=CLEARANCE) for v in done.vias)
    final = _after(geometry, done, req)
    final = BoardGeometry(final.outline, final.copper + dropped, final.edge_clearance)
    assert min(exact_gaps(final, req, done.path)) >= 0  # A keeps clear of both vias
    for leg in done.reroutes:  # each leg keeps clear of everything of other nets
        check = request("B", (10, 9.9), (10, 3), layer=leg.layer, width=leg.width)
        assert min(exact_gaps(final, check, leg.path)) >= 0
    legs = {r.layer: r.path for r in done.reroutes}
    via_points = {v.at for v in done.vias}
    assert {legs["B.Cu"][0], legs["B.Cu"][-1]} == via_points  # B.Cu runs via to via
    # Each pad of B reaches a via on F.Cu (a leg, or the via sits on the pad).
    ends = {p for r in done.reroutes if r.layer == "F.Cu" for p in (r.path[0], r.path[-1])}
    for pad_at in ((10 * MM, 9_900_000), (10 * MM, 3 * MM)):
        assert pad_at in ends or pad_at in via_points

"""The walkaround router's shortcuts: the ray screen that skips exact tests of links
that cannot be clear, the answers remembered per layer state, and paths no worse than the
router before them (revision 5a7faa8, recorded in data/d2_paths_5a7faa8.json)."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from pcbdata.router.geometry import CopperItem, bends, octilinear_length
from pcbdata.router.search import _link_segments, _LinkBatch, _Search
from pcbdata.router.walkaround import WalkaroundRouter
from tests.router.test_walkaround import MM, _pillar_maze, assert_legal, board, pad, request, wall

BASELINE = Path(__file__).parent / "data" / "d2_paths_5a7faa8.json"


def _exact_variants(search: _Search, v: int, targets: np.ndarray) -> np.ndarray:
    """(2, n): whether link variant 0 / 1 from node v to each target is clear (exact test)."""
    out = np.zeros((2, len(targets)), dtype=bool)
    for k in (0, 1):
        segments, owner = _link_segments(search.nodes[v], search.nodes[targets], k)
        bad = np.zeros(len(targets), dtype=bool)
        bad[owner[search.rules.failing(segments)]] = True
        out[k] = ~bad
    return out


def test_the_ray_screen_never_rules_out_a_clear_link():
    geometry, req = _pillar_maze()
    router = WalkaroundRouter(geometry)
    rules = router._rules(req.net, req.layer, req.width, req.clearance)
    search = _Search(router, rules, req.start, req.goal, time.perf_counter())
    search.nodes = np.concatenate([search.ends, search.corners])
    search.rows = np.arange(len(search.nodes))
    ruled_out = clear = total = 0
    for v in range(0, len(search.nodes), 7):
        targets = np.setdiff1d(np.arange(len(search.nodes)), [v])
        maybe = search._screen(v, targets)
        exact = _exact_variants(search, v, targets)
        assert not (exact & ~maybe).any(), f"node {v}: a clear link was ruled out"
        ruled_out += int((~maybe).sum())
        clear += int(exact.sum())
        total += exact.size
    # The screen does its job: nearly every blocked link variant is ruled out without the
    # exact test.
    assert clear > 0 and ruled_out >= 0.9 * (total - clear), (ruled_out, total, clear)


def test_a_link_batch_judges_each_link_as_its_variants_one_by_one():
    """Each segment once (an octilinear link is one segment for both variants), and a link is
    clear when a variant not ruled out is clear, as the exact test of each variant says."""
    geometry, req = _pillar_maze()
    router = WalkaroundRouter(geometry)
    rules = router._rules(req.net, req.layer, req.width, req.clearance)
    search = _Search(router, rules, req.start, req.goal, time.perf_counter())
    search.nodes = np.concatenate([search.ends, search.corners])
    rng = np.random.default_rng(3)
    straight = bent = 0
    for v in range(0, len(search.nodes), 5):
        targets = np.setdiff1d(np.arange(len(search.nodes)), [v])
        maybe = rng.random((2, len(targets))) < 0.8
        links = _LinkBatch(search.nodes[v], search.nodes[targets], maybe)
        links.judge(rules.failing(links.segments))
        exact = _exact_variants(search, v, targets)
        assert (links.clear == ((exact[0] & maybe[0]) | (exact[1] & maybe[1]))).all()
        straight += len(links.direct)
        bent += len(links.bent[0]) + len(links.bent[1])
    assert straight > 0 and bent > 0


def test_an_answer_is_remembered_until_its_layer_changes():
    items = [pad("A", 3, 10), pad("A", 17, 10), wall("B", 10, 4, 10, 16)]
    req = request("A", (3, 10), (17, 10))
    router = WalkaroundRouter(board(*items))
    first = router.route(req)
    assert first.path is not None and first.stats["method"] == "search"
    remembered = len(router._shared.routes)
    again = router.route(req)
    assert again.path == first.path and len(router._shared.routes) == remembered
    assert {k: v for k, v in again.stats.items() if k != "seconds"} == \
        {k: v for k, v in first.stats.items() if k != "seconds"}
    # Copper on another layer leaves the answer standing; copper on this one does not.
    other = CopperItem("track", "C", ("B.Cu",), start=(0, 0), end=(5 * MM, 5 * MM),
                       width=200_000, clearance=200_000)
    router.update(board(*items, other))
    assert router.route(req).path == first.path and len(router._shared.routes) == remembered
    block = wall("D", 10, 0.6, 10, 4)  # closes the side the first path went round
    changed = board(*items, other, block)
    router.update(changed)
    moved = router.route(req)
    assert len(router._shared.routes) == remembered + 1
    assert moved.path is not None and moved.path != first.path
    assert_legal(changed, req, moved.path)
    # A router made with `with_board` shares what was worked out.
    fresh = router.with_board(board(*items))
    assert fresh.route(req).path == first.path
    assert len(router._shared.routes) == remembered + 1


def test_paths_are_no_worse_than_before_on_d2_boards():
    """Every D2 connection that the router of revision 5a7faa8 found is found, no longer and
    with no more bends (the boards are routed net by net, as in test_walkaround)."""
    import pcbdata.testing.d2_routes as d2

    baseline = json.loads(BASELINE.read_text())
    found: dict[str, list] = {}

    class Recording(WalkaroundRouter):
        def route(self, req):
            result = super().route(req)
            path = result.path
            found[current].append(None if path is None else (
                sum(octilinear_length(a, b) for a, b in zip(path, path[1:])), bends(path)))
            return result

    original = d2.WalkaroundRouter
    d2.WalkaroundRouter = Recording
    try:
        for current, b in d2.d2_test_boards(len(baseline)):
            found[current] = []
            d2.route_board(current, b)
    finally:
        d2.WalkaroundRouter = original
    assert list(found) == list(baseline)
    for name, calls in baseline.items():
        assert len(found[name]) == len(calls), name
        for i, ((was_found, length, bend_count), now) in enumerate(zip(calls, found[name])):
            if not was_found:
                continue
            assert now is not None, f"{name} call {i}: no path where there was one"
            assert now[0] <= length + 1e-3 and now[1] <= bend_count, (name, i, now, length)


def test_rays_kept_from_a_state_with_less_copper_never_rule_out_a_clear_link():
    """A route on the maze fills the rules' ray bounds; with a new wall of another net across
    the maze, the new state's rules start from those bounds (stale where the wall crosses a
    ray, never too short), and the screen still never rules out a link the exact test finds
    clear. Removing copper gives no such start."""
    geometry, req = _pillar_maze()
    router = WalkaroundRouter(geometry)
    assert router.route(req).path is not None
    before = router._rules(req.net, req.layer, req.width, req.clearance)
    assert before.rays
    walled = board(*geometry.copper, wall("C", 5, 10, 15, 10, 0.3))
    router.update(walled)
    rules = router._rules(req.net, req.layer, req.width, req.clearance)
    assert rules is not before and rules.rays == before.rays  # seeded, not worked out again
    search = _Search(router, rules, req.start, req.goal, time.perf_counter())
    search.nodes = np.concatenate([search.ends, search.corners])
    search.rows = np.arange(len(search.nodes))
    for v in range(0, len(search.nodes), 5):
        targets = np.setdiff1d(np.arange(len(search.nodes)), [v])
        maybe = search._screen(v, targets)
        assert not (_exact_variants(search, v, targets) & ~maybe).any(), f"node {v}"
    assert WalkaroundRouter(walled).route(req).path == router.route(req).path
    router.update(board(*geometry.copper[:-1]))  # a pillar gone: old bounds may be too short
    assert not router._rules(req.net, req.layer, req.width, req.clearance).rays


def test_shapes_off_the_board_are_prepared_once_for_every_router_made_from_one(monkeypatch):
    """`WalkaroundRouter.prepared`: a board item's shape is the board's; an item off the
    board (a planner's soft copper) is prepared as a fresh preparation would, once for the
    router and those made from it (`with_board`), the least recently used forgotten first."""
    from pcbdata.router import walkaround
    from pcbdata.router.clearance import _prepare
    from pcbdata.router.geometry import copper_core

    geometry, _ = _pillar_maze()
    router = WalkaroundRouter(geometry)
    on_board = geometry.copper[0]
    assert router.prepared(on_board) is router._cache[on_board]
    off = [CopperItem("track", "X", ("F.Cu",), start=(k * MM, MM), end=(k * MM, 2 * MM),
                      width=200_000, clearance=200_000) for k in range(1, 5)]
    first = router.prepared(off[0])
    assert first == _prepare(*copper_core(off[0]))
    other = router.with_board(geometry)
    assert other.prepared(off[0]) is first  # remembered for the routers made from it
    monkeypatch.setattr(walkaround._Memory, "PREPARED", 2)
    for item in off[1:]:
        router.prepared(item)
    assert list(router._shared.prepared) == off[2:]  # the first two forgotten, oldest first

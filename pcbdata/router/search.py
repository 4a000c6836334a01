"""The walkaround router's A* search over octagon corner nodes (`_Search`), with its batched
link checks and the ray screen that skips links certain to collide."""
from __future__ import annotations

import time
from typing import Any

import numpy as np

from pcbdata.router import clearance_kernel, search_kernel
from pcbdata.router.clearance import _HEADING_INDEX, _ROOT2, _Rules, _segments
from pcbdata.router.corners import corner_nodes
from pcbdata.router.geometry import (
    Point,
    bends,
    direction,
    is_octilinear,
    octilinear_length,
    one_bend_paths,
    simplify_path,
)
from pcbdata.router.requests import RouteResult

# The search first looks at corners within this margin of the start-goal box (nm or share
# of its size, whichever is larger) and doubles it while that window holds no path.
WINDOW_MIN = 5_000_000
WINDOW_SHARE = 0.5
# Batches of links with fewer (link, obstacle) pairs than this skip the ray screen.
_SCREEN_PAIRS = 20_000
_SCREEN_LINKS = 64  # ... unless they hold this many links
# A search stops screening when, after this many link variants, it rules out less than this
# share of them.
_SCREEN_TRIAL = 2_000
_SCREEN_SHARE = 0.9
#: Where the router asks for it (`WalkaroundRouter.prove_separation`), a search that has made
#: this many link checks asks once whether its ends lie in separate parts of the free space
#: (`_Rules.separated`) and, if they do, stops: no path can exist. Few searches that succeed
#: get this far; most that fail would go on to the search budget.
SEPARATION_AFTER = 50_000


def _mm(point: Point) -> str:
    return f"({point[0] / 1e6:.4f}, {point[1] / 1e6:.4f}) mm"


class _Search:
    """A* over corner nodes inside a window around start and goal; node 0 is the start,
    node 1 the goal.

    Expanding a node checks, in one batch, its links to every node whose cost they would
    lower. When the window holds no path, it grows until it covers every node.
    """

    def __init__(
        self, router: Any, rules: _Rules, start: Point, goal: Point, clock: float
    ):
        self.router, self.rules, self.clock = router, rules, clock
        self.compiled = clearance_kernel.enabled()  # the link work compiled (`search_kernel`)
        self.start, self.goal = start, goal
        self.checks = self.expanded = 0
        self.screened = self.ruled_out = 0  # link variants put to the ray screen; ruled out
        self.asked = False  # whether the search asked `_Rules.separated` yet
        nodes = corner_nodes(router, rules)
        ends = np.array([start, goal], dtype=np.int64)
        self.corners = nodes[~(nodes[:, None, :] == ends[None]).all(axis=2).any(axis=1)]
        self.ends = ends
        # Ray bounds (`_Rules.free`) per node (row 0 start, 1 goal, 2 + i corner i) and
        # heading, found when first needed and kept while the window grows.
        self.free = np.full((2 + len(self.corners), 8), np.nan)
        self.points = np.concatenate([ends, self.corners]).astype(float)
        reach = float(np.hypot(*(self.points.max(axis=0) - self.points.min(axis=0)))) + 2.0
        if reach > rules.ray_reach:  # kept bounds may be infinite only for want of reach
            rules.rays.clear()
            rules.ray_reach = 2 * reach
        self.reach = rules.ray_reach

    def run(self) -> RouteResult:
        lo, hi = self.ends.min(axis=0), self.ends.max(axis=0)
        margin = max(WINDOW_MIN, WINDOW_SHARE * float((hi - lo).max()))
        while True:
            inside = np.all((self.corners >= lo - margin) & (self.corners <= hi + margin), axis=1)
            self.rows = np.concatenate([[0, 1], 2 + np.flatnonzero(inside)])
            result = self._astar(np.concatenate([self.ends, self.corners[inside]]))
            if result is not None or inside.all():
                return result or self._fail("no path: the obstacles enclose the start or the goal")
            if self._over_budget():
                return self._fail(self._budget_reason())
            margin *= 2

    def _over_budget(self) -> bool:
        router = self.router
        return (
            self.expanded >= router.budget_nodes
            or self.checks >= router.budget_checks
            or (
                router.budget_seconds is not None
                and time.perf_counter() - self.clock > router.budget_seconds
            )
        )

    def _separated(self) -> bool:
        """Whether the ends are proven apart (asked once, after `SEPARATION_AFTER` link
        checks, where the router asks for it); False where not asked or not proven."""
        if self.asked or self.checks < SEPARATION_AFTER or not self.router.prove_separation:
            return False
        self.asked = True
        return self.rules.separated(self.router._region, self.start, self.goal)

    def _budget_reason(self) -> str:
        router = self.router
        limits = [f"{router.budget_nodes} nodes", f"{router.budget_checks} link checks"]
        if router.budget_seconds is not None:
            limits.append(f"{router.budget_seconds:g} s")
        return f"no path within the search budget ({', '.join(limits)})"

    def _astar(self, nodes: np.ndarray) -> RouteResult | None:
        """A path through `nodes`, a failed result when out of budget, None when there is none."""
        self.nodes = nodes
        heuristic = _octilinear_to(nodes, self.goal)
        g = np.full(len(nodes), np.inf)
        parent = np.full(len(nodes), -1, dtype=np.int64)
        closed = np.zeros(len(nodes), dtype=bool)
        g[0] = 0.0
        while True:
            v = _pick(g, heuristic, closed, self.compiled)  # ties: the lowest index
            if v < 0:
                return None
            if self._over_budget():
                return self._fail(self._budget_reason())
            if self._separated():
                return self._fail("no path: the start and the goal lie in separate parts of "
                                  "the free space")
            closed[v] = True
            self.expanded += 1
            if v == 1:
                return self._finish(parent)
            targets, cost = _targets(nodes, v, g, closed, self.compiled)
            if len(targets):
                clear = self._links_clear(v, targets).any(axis=0)
                reached = targets[clear]
                g[reached] = cost[clear]
                parent[reached] = v

    def _links_clear(self, v: int, targets: np.ndarray) -> np.ndarray:
        """(2, n): whether variant 0 / 1 of the one-bend link from node v to each target node
        is clear (an octilinear link is the same segment in both; both variants are checked in
        one batch: fewer, larger geometry calls are faster); a target is reached where either
        is.

        Variants the ray screen proves blocked skip the exact test; the answer is the same."""
        a, ends = self.nodes[v], self.nodes[targets]
        self.checks += len(targets)
        big = len(targets) * self.rules.obstacles > _SCREEN_PAIRS or len(targets) >= _SCREEN_LINKS
        if big and self._screen_pays():
            maybe = self._screen(v, targets)
            self.screened += maybe.size
            self.ruled_out += int((~maybe).sum())
        else:  # a small batch: the exact test costs less than the rays
            maybe = np.ones((2, len(targets)), dtype=bool)
        links = _LinkBatch(a, ends, maybe, self.compiled)
        if len(links.segments):
            links.judge(self.rules.failing(links.segments))
        return links.variants

    def _screen_pays(self) -> bool:
        """Whether the screen still rules out enough to be worth its rays (on open boards
        most links are clear and the exact test alone is cheaper). Either way the answers
        are the same."""
        return self.screened < _SCREEN_TRIAL or self.ruled_out >= _SCREEN_SHARE * self.screened

    def _screen(self, v: int, targets: np.ndarray) -> np.ndarray:
        """(2, n): whether link variant 0 / 1 from v to each target may be clear. A variant is
        out when one of its two segments is longer than the ray bound from its node end (the
        first segment seen from v, the second from the target, looking back). Compiled where
        the clearance test is (`search_kernel`), the same answers."""
        if self.compiled:
            maybe, missing = search_kernel._screen(self.nodes, v, targets, self.rows,
                                                   self.free, _HEADING_INDEX)
            if len(missing):
                self._fill(np.stack([missing // 8, missing % 8], axis=1))
                maybe, _ = search_kernel._screen(self.nodes, v, targets, self.rows,
                                                 self.free, _HEADING_INDEX)
            return maybe
        d = self.nodes[targets] - self.nodes[v]
        m = np.minimum(np.abs(d[:, 0]), np.abs(d[:, 1]))
        diag = np.sign(d) * m[:, None]
        straight = d - diag
        h_straight = _HEADING_INDEX[np.sign(straight[:, 0]) + 1, np.sign(straight[:, 1]) + 1]
        h_diag = _HEADING_INDEX[np.sign(diag[:, 0]) + 1, np.sign(diag[:, 1]) + 1]
        len_straight = np.abs(straight).max(axis=1).astype(float)
        len_diag = m * _ROOT2
        rows = self.rows[targets]
        v_row = np.full(len(targets), self.rows[v])
        # The four segment ends in one batch: one lookup of missing ray bounds, not four.
        first0, second0, first1, second1 = self._too_long(
            np.concatenate([v_row, rows, v_row, rows]),
            np.concatenate([h_straight, _reverse(h_diag), h_diag, _reverse(h_straight)]),
            np.concatenate([len_straight, len_diag, len_diag, len_straight]),
        ).reshape(4, len(targets))
        return np.stack([~(first0 | second0), ~(first1 | second1)])

    def _fill(self, keys: np.ndarray) -> None:
        """Ray bounds for these (row, heading) pairs: from earlier searches under the same
        rules when they reached as far, else worked out now."""
        points = self.points[keys[:, 0]]
        names = [(x, y, h) for (x, y), h in zip(points.astype(np.int64).tolist(),
                                                keys[:, 1].tolist())]
        known = self.rules.rays
        bounds = np.array([known.get(name, np.nan) for name in names])
        todo = np.isnan(bounds)
        if todo.any():
            bounds[todo] = self.rules.free(points[todo], keys[todo, 1], self.reach)
            known.update(zip([n for n, t in zip(names, todo) if t], bounds[todo].tolist()))
        self.free[keys[:, 0], keys[:, 1]] = bounds

    def _too_long(self, rows: np.ndarray, headings: np.ndarray, lengths: np.ndarray):
        """Whether segments of these lengths from these nodes' rows along these headings
        (-1: no segment) certainly fail."""
        some = headings >= 0
        rows, headings = rows[some], headings[some]
        missing = np.isnan(self.free[rows, headings])
        if missing.any():  # (row, heading) pairs as one sortable code: a 1-D unique is cheap
            codes = np.unique(rows[missing].astype(np.int64) * 8 + headings[missing])
            self._fill(np.stack([codes // 8, codes % 8], axis=1))
        out = np.zeros(len(lengths), dtype=bool)
        out[some] = lengths[some] > self.free[rows, headings]
        return out

    def _link(self, a: Point, b: Point, heading) -> tuple[Point, ...] | None:
        """A clear straight or one-bend path a-b (points after a), preferring no bend at a."""
        options = sorted(one_bend_paths(a, b), key=lambda p: direction(p[0], p[1]) != heading)
        self.checks += 1
        for path in options:
            if not self.rules.failing(_segments(path)).any():
                return tuple(path[1:])
        return None

    def _finish(self, parent) -> RouteResult:
        chain, node = [1], 1
        while node != 0:
            node = int(parent[node])
            chain.append(node)
        corners = [(int(self.nodes[i][0]), int(self.nodes[i][1])) for i in reversed(chain)]
        path = self._shortcut(tuple(corners))
        stats = {
            "method": "search",
            "expanded": self.expanded,
            "checks": self.checks,
            "nodes": len(self.nodes),
        }
        if (
            path is None
            or self.rules.failing(_segments(path)).any()
            or not all(is_octilinear(a, b) for a, b in zip(path, path[1:]))
        ):
            return RouteResult(
                None, "internal error: the search path failed its final check", stats
            )
        stats["length"] = sum(octilinear_length(a, b) for a, b in zip(path, path[1:]))
        stats["bends"] = bends(path)
        return RouteResult(path, "", stats)

    def _shortcut(self, corners: tuple[Point, ...]) -> tuple[Point, ...] | None:
        """Joins the corners A* chose by links, each from a corner to the farthest later one a
        clear link reaches. A link is never longer than the corners it skips (octilinear
        length obeys the triangle inequality) and bends at most once, so this only shortens
        the path and removes bends."""
        out, i = [corners[0]], 0
        while i < len(corners) - 1:
            heading = direction(out[-2], out[-1]) if len(out) > 1 else None
            for j in range(len(corners) - 1, i, -1):
                link = self._link(corners[i], corners[j], heading)
                if link is not None:
                    out.extend(link)
                    i = j
                    break
            else:
                return None  # A* checked every consecutive link: cannot happen
        return simplify_path(out)

    def _fail(self, reason: str) -> RouteResult:
        return RouteResult(
            None,
            reason,
            {
                "method": "search",
                "expanded": self.expanded,
                "checks": self.checks,
                "nodes": len(self.corners) + 2,
            },
        )


def _link_segments(
    a: np.ndarray, targets: np.ndarray, variant: int
) -> tuple[np.ndarray, np.ndarray]:
    """Segments (k, 2, 2) of the links a -> targets and the link each belongs to.

    Variant 0 runs straight then 45 degrees, variant 1 45 degrees then straight; an
    octilinear link is its one segment in both.
    """
    d = targets - a
    m = np.minimum(np.abs(d[:, 0]), np.abs(d[:, 1]))
    diag = np.sign(d) * m[:, None]
    bend = targets - diag if variant == 0 else a + diag
    straight = _is_octilinear(a, targets)
    a_rep = np.broadcast_to(a, targets.shape)
    first = np.stack([a_rep, bend], axis=1)[~straight]
    second = np.stack([bend, targets], axis=1)[~straight]
    direct = np.stack([a_rep, targets], axis=1)[straight]
    owners = np.arange(len(targets))
    segments = np.concatenate([direct, first, second]).astype(float)
    owner = np.concatenate([owners[straight], owners[~straight], owners[~straight]])
    return segments, owner


class _LinkBatch:
    """The segments of the link variants still in question from node a to each end, each
    segment once: an octilinear link is one segment, the same in both variants.

    `judge(failing)` takes the exact verdict per segment; `variants` then says, per variant
    and end, whether that variant of the link is clear, and `clear`, per end, whether one of
    them is (a variant ruled out before counts as blocked)."""

    def __init__(self, a: np.ndarray, ends: np.ndarray, maybe: np.ndarray,
                 compiled: bool = False):
        self.variants = np.zeros((2, len(ends)), dtype=bool)
        if compiled:  # the same segments, in one compiled pass (`search_kernel`)
            self.segments, self.direct, *self.bent = search_kernel._batch_segments(a, ends,
                                                                                   maybe)
            return
        d = ends - a
        m = np.minimum(np.abs(d[:, 0]), np.abs(d[:, 1]))
        diag = np.sign(d) * m[:, None]
        straight = _is_octilinear(a, ends)
        self.direct = np.flatnonzero(straight & (maybe[0] | maybe[1]))
        self.bent = [np.flatnonzero(~straight & maybe[k]) for k in (0, 1)]
        # Variant 0 runs straight then 45 degrees, variant 1 45 degrees then straight.
        knees = [ends[self.bent[0]] - diag[self.bent[0]], a + diag[self.bent[1]]]
        firsts = len(self.direct) + len(self.bent[0])
        starts = np.concatenate([np.broadcast_to(a, (firsts, 2)), knees[0],
                                 np.broadcast_to(a, (len(self.bent[1]), 2)), knees[1]])
        stops = np.concatenate([ends[self.direct], knees[0], ends[self.bent[0]],
                                knees[1], ends[self.bent[1]]])
        self.segments = np.stack([starts, stops], axis=1).astype(float)

    @property
    def clear(self) -> np.ndarray:
        return np.asarray(self.variants.any(axis=0))

    def judge(self, failing: np.ndarray) -> None:
        at = len(self.direct)
        self.variants[:, self.direct] = ~failing[:at]
        for k in (0, 1):
            count = len(self.bent[k])
            ok = ~(failing[at : at + count] | failing[at + count : at + 2 * count])
            self.variants[k, self.bent[k]] = ok
            at += 2 * count


def _reverse(headings: np.ndarray) -> np.ndarray:
    return np.where(headings >= 0, (headings + 4) % 8, -1)


def _is_octilinear(a: np.ndarray, targets: np.ndarray) -> np.ndarray:
    d = np.abs(targets - a)
    return (d[:, 0] == 0) | (d[:, 1] == 0) | (d[:, 0] == d[:, 1])


def _pick(g: np.ndarray, heuristic: np.ndarray, closed: np.ndarray, compiled: bool) -> int:
    """The open node of least g + heuristic, the lowest index among equals; -1 when none is
    finite."""
    if compiled:
        return int(search_kernel._pick(g, heuristic, closed))
    f = np.where(closed, np.inf, g + heuristic)
    v = int(np.argmin(f))
    return v if np.isfinite(f[v]) else -1


def _targets(nodes: np.ndarray, v: int, g: np.ndarray, closed: np.ndarray,
             compiled: bool) -> tuple[np.ndarray, np.ndarray]:
    """The open nodes whose cost through node v is below their g, and those costs."""
    if compiled:
        return search_kernel._targets(nodes, v, float(g[v]), g, closed)
    cost = g[v] + _octilinear_to(nodes, tuple(nodes[v]))
    targets = np.flatnonzero(~closed & (cost < g))
    return targets, cost[targets]


def _octilinear_to(points: np.ndarray, target: Point) -> np.ndarray:
    d = np.abs(points - np.asarray(target, dtype=points.dtype)).astype(float)
    return d.max(axis=1) + (_ROOT2 - 1) * d.min(axis=1)

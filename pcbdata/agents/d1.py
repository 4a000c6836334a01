"""`D1Agent`: D1 boards planned on their lattice (Connector's problem: one net per cell) with
net ordering, rip-up and reroute and seeded retries, then laid cell by cell through the
environment's own actions; it reads only the observation and `info`."""
from __future__ import annotations

import numpy as np

from pcbdata.agents.scripted import ScriptedAgent, action, open_edges
from pcbdata.env.types import (
    MAKE_LINE,
    NET_END,
    START_ROUTE,
    WALKAROUND,
)

_NEIGHBOURS = ((1, 0), (0, 1), (-1, 0), (0, -1))
_RIP_PENALTY = 8  # a cell of another net's planned path costs this many free cells
_RIP_ROUNDS = 60  # rip-ups per planning attempt
_ATTEMPTS = 24  # planning attempts (net orders) per episode
_STEP_BUDGET = 190
_PAD_SIDE_COST = 0.3
_NOISE = 0.5  # of the environment's 200 steps: plans that need more use `finish`


class D1Grid:
    """A D1 board's lattice read from the observation (mm): pitch g, pad centres at
    (i + 0.75) g, square pads of side g/2, so a track along lattice lines keeps exactly the
    clearance to the next cell's copper and to the edge. Cells hold at most one net."""

    def __init__(self, obs):
        static = obs["board_static"]
        pads = static["pads"][static["pads"][:, 0] == 1]
        self.pitch = 2.0 * float(pads[0, 4])
        side = float(static["outline"][:, 0].max())
        self.size = round((side - 0.5 * self.pitch) / self.pitch)
        self.pads: dict[int, list[tuple[int, int]]] = {}
        for row in pads:
            self.pads.setdefault(int(row[1]), []).append(self.cell(float(row[2]), float(row[3])))

    @classmethod
    def of(cls, pitch: float, size: int, pads: dict) -> D1Grid:
        """A grid from its parts (pitch in mm, cells per side, net -> pad cells)."""
        grid = cls.__new__(cls)
        grid.pitch, grid.size, grid.pads = pitch, size, pads
        return grid

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return (round(x / self.pitch - 0.75), round(y / self.pitch - 0.75))

    def centre(self, cell: tuple[int, int]) -> tuple[float, float]:
        return ((cell[0] + 0.75) * self.pitch, (cell[1] + 0.75) * self.pitch)

    def pad_owner(self) -> dict[tuple[int, int], int]:
        return {c: net for net, cells in self.pads.items() for c in cells}

    def walled_nets(self) -> list[int]:
        """Nets with no lattice path even with every other net's tracks gone (only pads in
        the way): no agent connects them, so they bound CP from above."""
        owner = self.pad_owner()
        return [net for net, cells in sorted(self.pads.items())
                if len(cells) == 2
                and _cheapest(self.size, owner, net, cells[0], cells[1], None) is None]


def _cheapest(size: int, owner: dict, net: int, start, goal, paths_owner: dict | None,
              extra: np.ndarray | None = None):
    """The cheapest 4-connected cell path start..goal (Dijkstra, ties by cell), or None.
    Cells `owner` gives another net are walls; a free cell costs 1 + `extra` there, a cell
    `paths_owner` gives another net (a planned path that may be ripped up) _RIP_PENALTY more."""
    import heapq

    best = {start: 0.0}
    parent: dict = {}
    heap = [(0.0, start)]
    while heap:
        cost, cell = heapq.heappop(heap)
        if cell == goal:
            path = [cell]
            while path[-1] != start:
                path.append(parent[path[-1]])
            return path[::-1]
        if cost > best.get(cell, np.inf):
            continue
        for dx, dy in _NEIGHBOURS:
            nxt = (cell[0] + dx, cell[1] + dy)
            if not (0 <= nxt[0] < size and 0 <= nxt[1] < size) or owner.get(nxt, net) != net:
                continue
            step = 1.0 if extra is None else 1.0 + float(extra[nxt])
            if paths_owner is not None and paths_owner.get(nxt, net) != net:
                step += _RIP_PENALTY
            if cost + step < best.get(nxt, np.inf):
                best[nxt] = cost + step
                parent[nxt] = cell
                heapq.heappush(heap, (cost + step, nxt))
    return None


def cell_costs(grid: D1Grid, rng: np.random.Generator | None) -> np.ndarray:
    """Extra cost per cell: next to a pad (a path there may wall a net in), plus seeded noise
    that makes each planning attempt break ties differently (none without `rng`)."""
    extra = np.zeros((grid.size, grid.size))
    for cell in grid.pad_owner():
        for dx, dy in _NEIGHBOURS:
            x, y = cell[0] + dx, cell[1] + dy
            if 0 <= x < grid.size and 0 <= y < grid.size:
                extra[x, y] += _PAD_SIDE_COST
    if rng is not None:
        extra += rng.random(extra.shape) * _NOISE
    return extra


def plan_d1(grid: D1Grid, order: list[int], extra: np.ndarray | None = None,
            rounds: int = _RIP_ROUNDS) -> dict[int, list]:
    """Lattice paths for as many nets as it can: nets in `order`, each on free cells if it
    can, else through other nets' paths, which are ripped up and queued again."""
    pads = grid.pad_owner()
    used: dict[tuple[int, int], int] = {}  # path cells (pads excluded) -> net
    paths: dict[int, list] = {}
    queue, ripped = list(order), 0
    while queue and ripped <= rounds:
        net = queue.pop(0)
        if len(grid.pads.get(net, [])) != 2:
            continue
        start, goal = grid.pads[net]
        owner = {**pads, **{c: n for c, n in used.items() if n != net}}
        path = _cheapest(grid.size, owner, net, start, goal, None, extra)
        if path is None:
            path = _cheapest(grid.size, pads, net, start, goal, used, extra)
            if path is None:
                continue  # walled in by pads
            for victim in sorted({used[c] for c in path if used.get(c, net) != net}):
                used = {c: n for c, n in used.items() if n != victim}
                paths.pop(victim, None)
                queue.append(victim)
            ripped += 1
        paths[net] = path
        used.update({c: net for c in path if c not in pads})
    return paths


def _plan_cost(paths: dict) -> tuple[int, int]:
    return (-len(paths), sum(len(p) for p in paths.values()))


class D1Agent(ScriptedAgent):
    """D1's agent (`--agent d1`): plans every net on the board's
    lattice (Connector's problem: 4-connected cell paths, one net per cell) with net ordering
    and rip-up and reroute of the nets that block an open one, then lays the plan cell by cell
    with `make_line` to the lattice ring candidates (walkaround mode: KiCad judges each step).
    Seed 0 tries the nets shortest first; other seeds start from a seeded order, so @k is k
    different tries. When the plan needs more steps than the episode has (large grids), or on
    a board that is not D1, it routes like `ShovingScriptedAgent` (`finish` in walkaround,
    then push_n_shove), nets in the planned order."""

    def __init__(self, seed: int = 0, tries_per_net: int = 6):
        super().__init__(seed, tries_per_net, WALKAROUND, shove=True)

    def _new_episode(self, obs) -> None:
        super()._new_episode(obs)
        self._plan: dict[int, list] = {}
        self._cursor: dict[int, int] = {}
        if int(obs["board_static"]["n_layers"]) == 2 and self._is_lattice(obs):
            self._plan_lattice(obs)

    @staticmethod
    def _is_lattice(obs) -> bool:
        static = obs["board_static"]
        pads = static["pads"][static["pads"][:, 0] == 1]
        if not len(pads) or not np.all(pads[:, 4] == pads[0, 4]) \
                or int(static["pad_layers"][:, 1:].sum()):
            return False
        offsets = pads[:, 2:4] / (2.0 * pads[0, 4]) - 0.75  # whole numbers on D1's lattice
        return bool(np.all(np.abs(offsets - np.round(offsets)) < 1e-6))

    def _plan_lattice(self, obs) -> None:
        grid = D1Grid(obs)
        self._grid = grid
        shortest = sum(abs(a[0] - b[0]) + abs(a[1] - b[1]) + 3 for a, b in
                       (cells for cells in grid.pads.values() if len(cells) == 2))
        if shortest > _STEP_BUDGET:  # no lattice plan fits the episode: route with `finish`
            return
        rng = np.random.default_rng(self.seed)
        best: dict[int, list] = {}
        for attempt in range(_ATTEMPTS):
            order = list(self._order)
            if attempt or self.seed:
                rng.shuffle(order)
            paths = plan_d1(grid, order, cell_costs(grid, rng if attempt else None))
            if not best or _plan_cost(paths) < _plan_cost(best):
                best, best_order = paths, [n for n in order if n in paths]
            if len(best) == len(grid.pads):
                break
        steps = sum(len(p) + 2 for p in best.values())
        if best and steps <= _STEP_BUDGET:
            self._plan = best
            self._order = best_order + [n for n in self._order if n not in best]

    def _start(self, obs, info) -> dict:
        net = int(obs["router_head"]["net"])
        if net not in self._plan:
            return super()._start(obs, info)
        if net in self._cursor:  # a planned net that went wrong: give it up
            self._gave_up.add(net)
            return action(NET_END)
        self._cursor[net] = 0
        return self._to_cell(obs, info, self._plan[net][0], START_ROUTE)

    def _route(self, obs, info) -> dict:
        net = int(obs["router_head"]["net"])
        if net not in self._plan:
            return super()._route(obs, info)
        if not any(int(e[1]) == net for e in open_edges(obs)):
            return action(NET_END)
        path, head = self._plan[net], obs["router_head"]["position"]
        here = self._grid.cell(float(head[0]), float(head[1]))
        if here != path[self._cursor[net]] or self._cursor[net] + 1 >= len(path):
            self._gave_up.add(net)  # a step was refused: the plan no longer holds
            return action(NET_END)
        self._cursor[net] += 1
        return self._to_cell(obs, info, path[self._cursor[net]], MAKE_LINE)

    def _to_cell(self, obs, info, cell, kind: int) -> dict:
        x, y = self._grid.centre(cell)
        mask = info["action_mask"]["candidate"]
        for i, c in enumerate(obs["router_head"]["candidates"]):
            if mask[i] and c[0] != 0 and abs(c[1] - x) < 1e-6 and abs(c[2] - y) < 1e-6 \
                    and int(c[3]) == 0:
                return action(kind, candidate=i, mode=WALKAROUND)
        net = int(obs["router_head"]["net"])
        self._gave_up.add(net)
        return action(NET_END)

"""Jumanji's own Connector environment on a D1 split's instances, and a greedy grid policy.

`ArraysGenerator` feeds the split's Connector arrays into Jumanji's `State`: the row comes from
the reset key (`row_key(row)`), so one jitted `reset` serves every board. `GreedyPolicy` plans
on the first observation, agent after agent (shortest start-target distance first), a
breadth-first cell path over empty cells and its own target, then moves every agent along its
plan at once (the plans are disjoint, so no two heads collide). `rollout_split` runs it over a
split and returns the final grids and what Jumanji reports: the input of `convert_rollouts`.

Needs the `jumanji` extra (`pip install "pcbdata[jumanji]"`: JAX on the CPU).
"""
from __future__ import annotations

import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from pcbdata.core.errors import UserError
from pcbdata.core.tree import arrays_path

UP, RIGHT, DOWN, LEFT = 1, 2, 3, 4
_MOVES = {(-1, 0): UP, (0, 1): RIGHT, (1, 0): DOWN, (0, -1): LEFT}


def _jumanji():
    try:
        import jax
        import jax.numpy as jnp
        from jumanji.environments import Connector
        from jumanji.environments.routing.connector.generator import Generator
        from jumanji.environments.routing.connector.types import Agent, State
        from jumanji.environments.routing.connector.utils import (
            get_action_masks,
            get_position,
            get_target,
        )
    except ImportError as exc:
        raise UserError(f"Jumanji is not installed ({exc}); pip install 'pcbdata[jumanji]'") \
            from None
    return (jax, jnp, Connector, Generator, Agent, State, get_action_masks, get_position,
            get_target)


def row_key(row: int):
    """The reset key that makes `ArraysGenerator` return row `row`."""
    import jax.numpy as jnp

    return jnp.array([0, row], dtype=jnp.uint32)


def make_env(starts: np.ndarray, targets: np.ndarray, grid_size: int):
    """Jumanji's `Connector` whose reset(row_key(r)) is row r of the arrays; the time limit is
    the cell count, so a greedy plan never runs out of steps."""
    jax, jnp, Connector, Generator, Agent, State, masks, position, target = _jumanji()

    base: Any = Generator  # Jumanji's class, imported at run time

    class ArraysGenerator(base):
        def __init__(self):
            super().__init__(grid_size, int(starts.shape[1]))
            self._starts = jnp.asarray(starts, dtype=jnp.int32)
            self._targets = jnp.asarray(targets, dtype=jnp.int32)

        def __call__(self, key):
            row = key[1].astype(jnp.int32)
            s, t = self._starts[row], self._targets[row]
            ids = jnp.arange(self.num_agents)
            grid = jnp.zeros((grid_size, grid_size), dtype=jnp.int32)
            grid = grid.at[s[:, 0], s[:, 1]].set(jax.vmap(position)(ids))
            grid = grid.at[t[:, 0], t[:, 1]].set(jax.vmap(target)(ids))
            agents = jax.vmap(Agent)(id=ids, start=s, target=t, position=s)
            return State(key=key, grid=grid, step_count=jnp.array(0, jnp.int32),
                         agents=agents, action_mask=masks(agents, grid))

    return Connector(generator=ArraysGenerator(), time_limit=grid_size * grid_size)


class GreedyPolicy:
    """Breadth-first paths planned agent after agent on Connector's grid, then played."""

    def __init__(self, grid: np.ndarray, starts: np.ndarray, targets: np.ndarray):
        self.plans = plan_paths(grid, starts, targets)

    @property
    def steps(self) -> int:
        return max((len(p) - 1 for p in self.plans), default=0)

    def actions(self, step: int) -> np.ndarray:
        out = np.zeros(len(self.plans), dtype=np.int32)
        for agent, plan in enumerate(self.plans):
            if step + 1 < len(plan):
                (i, j), (a, b) = plan[step], plan[step + 1]
                out[agent] = _MOVES[(a - i, b - j)]
        return out


def plan_paths(grid: np.ndarray, starts: np.ndarray, targets: np.ndarray) -> list[list]:
    """One cell path per agent (only its start when no path is left), planned in order of
    start-target distance; a planned path blocks the later agents."""
    free = np.asarray(grid) == 0
    order = sorted(range(len(starts)), key=lambda a: (int(np.abs(starts[a] - targets[a]).sum()),
                                                      a))
    plans: list[list] = [[tuple(map(int, s))] for s in starts]
    for agent in order:
        path = _bfs(free, tuple(map(int, starts[agent])), tuple(map(int, targets[agent])))
        if path is not None:
            plans[agent] = path
            for cell in path:
                free[cell] = False
    return plans


def _bfs(free: np.ndarray, start: tuple, goal: tuple) -> list | None:
    size = free.shape[0]
    previous: dict[tuple, tuple | None] = {start: None}
    queue = deque([start])
    while queue:
        cell = queue.popleft()
        if cell == goal:
            path: list = []
            back: tuple | None = cell
            while back is not None:
                path.append(back)
                back = previous[back]
            return path[::-1]
        i, j = cell
        for nxt in ((i - 1, j), (i, j + 1), (i + 1, j), (i, j - 1)):
            if (0 <= nxt[0] < size and 0 <= nxt[1] < size and nxt not in previous
                    and (free[nxt] or nxt == goal)):
                previous[nxt] = cell
                queue.append(nxt)
    return None


def rollout_split(set_root: str | Path, config: str, split: str,
                  limit: int | None = None) -> dict:
    """Greedy rollouts in Jumanji's Connector on the split's first `limit` rows: `grids`
    [M, G, G] (final states), `board_ids`, `time_s` (plan and steps), `ratio_connections`
    (Jumanji's own count) and `num_connections`."""
    jax = _jumanji()[0]
    with np.load(arrays_path(set_root, config, split), allow_pickle=False) as data:
        starts, targets = data["starts"], data["targets"]
        ids, grid_size = [str(b) for b in data["board_ids"]], int(data["grid_size"])
    env = make_env(starts, targets, grid_size)
    reset, step = jax.jit(env.reset), jax.jit(env.step)
    rows = range(len(ids) if limit is None else min(limit, len(ids)))
    step(reset(row_key(0))[0], np.zeros(len(starts[0]), dtype=np.int32))  # compile untimed
    out: dict[str, list] = {"grids": [], "time_s": [], "ratio_connections": [],
                            "num_connections": []}
    for row in rows:
        began = time.perf_counter()
        state, timestep = reset(row_key(row))
        policy = GreedyPolicy(np.asarray(state.grid), starts[row], targets[row])
        for k in range(policy.steps):
            state, timestep = step(state, policy.actions(k))
        grid = np.asarray(state.grid)
        out["time_s"].append(time.perf_counter() - began)
        out["grids"].append(grid)
        out["ratio_connections"].append(float(timestep.extras["ratio_connections"]))
        out["num_connections"].append(int(timestep.extras["num_connections"]))
    return {"grids": np.asarray(out["grids"], dtype=np.int32),
            "board_ids": np.asarray(ids[: len(rows)], dtype=str),
            "time_s": np.asarray(out["time_s"]),
            "ratio_connections": np.asarray(out["ratio_connections"]),
            "num_connections": np.asarray(out["num_connections"], dtype=np.int32)}

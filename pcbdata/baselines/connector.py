"""Connector solutions (grid-action agents, Jumanji) to routed D1 boards that `pcbdata eval` scores.

A D1 split exports its instances as Connector arrays (`<split>.npz`, `pcbdata.model.connector`):
`starts`/`targets` [N, A, 2] cells (i, j), the pad of cell (i, j) centred at ((i + 0.75) g,
(j + 0.75) g) mm. A grid-action agent's result on such a row is either Jumanji Connector's final
grid or one cell path per agent; each agent's path becomes tracks on a copy of the instance's
`board.kicad_pcb`: F.Cu, the instance's track width, the net of the pads at the agent's start and
target, one segment per straight run through the cell centres.

Connector's grid encoding (jumanji.environments.routing.connector.constants/utils, agent a from
0): 0 empty, 1 + 3a path, 2 + 3a position (the agent's head), 3 + 3a target. The start cell turns
into path once the agent moves; a connected agent's head sits on its target.

Solutions file (`.npz`, no pickles): `grids` int [M, G, G] or [M, K, G, G] (K rollouts per row),
or `paths` int [M, A, L, 2] or [M, K, A, L, 2] (agent a's cells from its start, padded with -1);
optional `board_ids` str [M] (default: the split's rows in order, M <= N) and `time_s` float [M]
or [M, K] (wall seconds per rollout, written to `<k>.json` for the evaluator's Time).
"""
from __future__ import annotations

import json
import re
import uuid
from collections import deque
from collections.abc import Sequence
from decimal import Decimal
from pathlib import Path

import numpy as np

from pcbdata.core.copper_text import top_level_blocks
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import write_atomic
from pcbdata.core.hashing import sha256_text
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, arrays_path, board_dir
from pcbdata.generators.d1 import D1Params
from pcbdata.model.kicad_writer import mm as _mm

Cell = tuple[int, int]
PATH, POSITION, TARGET = 1, 2, 3  # Connector's values for agent 0; agent a adds 3a
_NET_DECL = re.compile(r'^\(net\s+(\d+)\s+"((?:[^"\\]|\\.)*)"\)$', re.DOTALL)
_AT = re.compile(r"\(at\s+(-?[\d.]+)\s+(-?[\d.]+)")
_PAD_NET = re.compile(r'\(net\s+(\d+)\s+"')


def grid_to_paths(grid, starts, targets) -> list[list[Cell]]:
    """Each agent's cells from its start to its head, read from a final Connector grid. The
    trail is followed breadth-first, so a trail that touches itself gives the shorter path."""
    grid = np.asarray(grid)
    if grid.ndim != 2 or grid.shape[0] != grid.shape[1]:
        raise UserError(f"a Connector grid must be square [G, G], got shape {grid.shape}")
    return [_trail(grid, a, _cell(s), _cell(t)) for a, (s, t) in enumerate(zip(starts, targets))]


def _cell(pair) -> Cell:
    return int(pair[0]), int(pair[1])


def _trail(grid: np.ndarray, agent: int, start: Cell, target: Cell) -> list[Cell]:
    mine = {PATH + 3 * agent, POSITION + 3 * agent}
    heads = [(int(i), int(j)) for i, j in zip(*np.nonzero(grid == POSITION + 3 * agent))]
    if len(heads) != 1:
        raise UserError(f"Connector grid: agent {agent} has {len(heads)} head cells "
                        f"(value {POSITION + 3 * agent}), expected 1")
    if int(grid[start]) not in mine:
        raise UserError(f"Connector grid: agent {agent}'s start cell {start} holds "
                        f"{int(grid[start])}, not its path or head: grid and arrays disagree")
    path = _bfs(grid, mine, start, heads[0])
    if path is None:
        raise UserError(f"Connector grid: agent {agent}'s head {heads[0]} is not joined to its "
                        f"start {start} by its path cells")
    if heads[0] != target and int(grid[target]) != TARGET + 3 * agent:
        raise UserError(f"Connector grid: agent {agent}'s target cell {target} holds "
                        f"{int(grid[target])}: grid and arrays disagree")
    return path


def _bfs(grid: np.ndarray, mine: set[int], start: Cell, goal: Cell) -> list[Cell] | None:
    size = grid.shape[0]
    previous: dict[Cell, Cell | None] = {start: None}
    queue = deque([start])
    while queue:
        cell = queue.popleft()
        if cell == goal:
            return _walk_back(previous, goal)
        i, j = cell
        for nxt in ((i - 1, j), (i, j + 1), (i + 1, j), (i, j - 1)):
            if (0 <= nxt[0] < size and 0 <= nxt[1] < size and nxt not in previous
                    and int(grid[nxt]) in mine):
                previous[nxt] = cell
                queue.append(nxt)
    return None


def _walk_back(previous: dict[Cell, Cell | None], goal: Cell) -> list[Cell]:
    path: list[Cell] = []
    cell: Cell | None = goal
    while cell is not None:
        path.append(cell)
        cell = previous[cell]
    return path[::-1]


def corners(path: Sequence[Cell]) -> list[Cell]:
    """The path's end cells and turning cells: one segment per straight run between them."""
    if len(path) < 2:
        return list(path)
    out = [path[0]]
    for prev, cur, nxt in zip(path, path[1:], path[2:]):
        if (cur[0] - prev[0], cur[1] - prev[1]) != (nxt[0] - cur[0], nxt[1] - cur[1]):
            out.append(cur)
    out.append(path[-1])
    return out


def check_path(path: Sequence[Cell], grid_size: int, agent: int) -> None:
    for cell in path:
        if not (0 <= cell[0] < grid_size and 0 <= cell[1] < grid_size):
            raise UserError(f"agent {agent}'s path leaves the {grid_size} x {grid_size} grid "
                            f"at {cell}")
    for a, b in zip(path, path[1:]):
        if abs(a[0] - b[0]) + abs(a[1] - b[1]) != 1:
            raise UserError(f"agent {agent}'s path jumps from {a} to {b}: cells of a path must "
                            f"be 4-neighbours")


class BoardText:
    """What the converter reads from an instance's `board.kicad_pcb`: net numbers and the cell
    of every pad, checked against D1's lattice."""

    def __init__(self, text: str, grid_size: int, where: str):
        self.text, self.where = text, where
        self.pitch = D1Params(grid_size).pitch_nm
        self.grid_size = grid_size
        data = text.encode()
        blocks = [(h, data[s:e].decode()) for h, s, e in top_level_blocks(data)]
        self.nets = {int(m[1]): m[2] for h, b in blocks if h == "net"
                     for m in [_NET_DECL.match(b)] if m}
        self.pad_nets: dict[Cell, int] = {}
        for head, block in blocks:
            if head == "footprint":
                self._add_pad(block)

    def _add_pad(self, block: str) -> None:
        at, net = _AT.search(block), _PAD_NET.search(block)
        if at is None or net is None:
            return
        x, y = (_nm(v) for v in at.groups())
        cell = (round(x / self.pitch - 0.75), round(y / self.pitch - 0.75))
        if self.centre(cell) != (x, y):
            raise UserError(f"{self.where}: a pad at ({at[1]}, {at[2]}) mm is not on the D1 "
                            f"lattice of grid {self.grid_size}")
        self.pad_nets[cell] = int(net[1])

    def centre(self, cell: Cell) -> tuple[int, int]:
        """The centre of cell (i, j) in nm: the first index is x (as the generator places pads)."""
        g = self.pitch
        return round((4 * cell[0] + 3) * g / 4), round((4 * cell[1] + 3) * g / 4)

    def net_of(self, agent: int, start: Cell, target: Cell) -> int:
        nets = {self.pad_nets.get(start), self.pad_nets.get(target)}
        if len(nets) != 1 or None in nets:
            raise UserError(f"{self.where}: agent {agent}'s cells {start} and {target} are not "
                            f"the two pads of one net: board and Connector arrays disagree")
        return nets.pop()  # type: ignore[return-value]


def _nm(mm_text: str) -> int:
    return int((Decimal(mm_text) * 1_000_000).to_integral_value())


def track_width_nm(project_text: str, where: str) -> int:
    try:
        classes = json.loads(project_text)["net_settings"]["classes"]
        default = next(c for c in classes if c.get("name") == "Default")
        return _nm(str(default["track_width"]))
    except (ValueError, KeyError, TypeError, StopIteration):
        raise UserError(f"{where}: no Default net class track width") from None


def segments_text(board: BoardText, paths: Sequence[Sequence[Cell]], starts, targets,
                  width_nm: int, uuid_seed: str) -> str:
    """KiCad `segment` blocks for every agent's path (agents that never moved add nothing)."""
    out, count = [], 0
    for agent, path in enumerate(paths):
        check_path(path, board.grid_size, agent)
        if len(path) < 2:
            continue
        if tuple(path[0]) not in {_cell(starts[agent]), _cell(targets[agent])}:
            raise UserError(f"agent {agent}'s path begins at {tuple(path[0])}, not at its "
                            f"start {_cell(starts[agent])} or target {_cell(targets[agent])}")
        net = board.net_of(agent, _cell(starts[agent]), _cell(targets[agent]))
        ends = [board.centre(c) for c in corners(path)]
        for (x1, y1), (x2, y2) in zip(ends, ends[1:]):
            count += 1
            uid = uuid.UUID(hex=sha256_text(f"{uuid_seed}/{count}")[:32], version=4)
            out.append(f"\t(segment\n\t\t(start {_mm(x1)} {_mm(y1)})\n\t\t(end {_mm(x2)} "
                       f"{_mm(y2)})\n\t\t(width {_mm(width_nm)})\n\t\t(layer \"F.Cu\")\n"
                       f"\t\t(net {net})\n\t\t(uuid \"{uid}\")\n\t)\n")
    return "".join(out)


def insert_items(text: str, items: str) -> str:
    """The board text with `items` added as top-level blocks (before `embedded_fonts`, where
    KiCad writes its tracks, else after the last block)."""
    data = text.encode()
    blocks = top_level_blocks(data)
    if not blocks:
        raise UserError("not a KiCad board: no top-level blocks")
    fonts = [s for h, s, _ in blocks if h == "embedded_fonts"]
    if fonts:
        at = data.rfind(b"\n", 0, fonts[-1]) + 1
        return (data[:at] + items.encode() + data[at:]).decode()
    end = blocks[-1][2]
    return (data[:end] + b"\n" + items.rstrip("\n").encode() + data[end:]).decode()


def paths_to_board(instance_dir: str | Path, grid_size: int, paths: Sequence[Sequence[Cell]],
                   starts, targets, uuid_seed: str = "") -> str:
    """The text of the instance's board with the agents' paths as tracks."""
    folder = Path(instance_dir)
    where = str(folder / BOARD_FILE)
    try:
        text = (folder / BOARD_FILE).read_text()
        project = (folder / PROJECT_FILE).read_text()
    except OSError as exc:
        raise UserError(f"{where}: cannot read the instance ({exc.strerror})") from None
    board = BoardText(text, grid_size, where)
    width = track_width_nm(project, str(folder / PROJECT_FILE))
    seed = uuid_seed or f"connector/{folder.name}"
    return insert_items(text, segments_text(board, paths, starts, targets, width, seed))


def load_solutions(path: str | Path) -> dict:
    """The solutions file's arrays, with a rollout axis: `grids` [M, K, G, G] or `paths`
    [M, K, A, L, 2], `time_s` [M, K] or None, `board_ids` or None."""
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except (OSError, ValueError) as exc:
        raise UserError(f"{path}: not a readable .npz solutions file ({exc})") from None
    kinds = [k for k in ("grids", "paths") if k in arrays]
    if len(kinds) != 1:
        raise UserError(f"{path}: needs exactly one of 'grids' or 'paths', has "
                        f"{', '.join(sorted(arrays)) or 'nothing'}")
    kind = kinds[0]
    values = np.asarray(arrays[kind])
    base = 3 if kind == "grids" else 4
    if values.ndim == base:
        values = values[:, None]
    if values.ndim != base + 1:
        raise UserError(f"{path}: '{kind}' has shape {values.shape}; see the solutions format "
                        f"in docs/d1.md")
    times = arrays.get("time_s")
    if times is not None:
        times = np.asarray(times, dtype=float).reshape(values.shape[0], -1)
        if times.shape[1] != values.shape[1]:
            raise UserError(f"{path}: 'time_s' has shape {times.shape}, expected "
                            f"{values.shape[:2]}")
    ids = arrays.get("board_ids")
    return {"kind": kind, "values": values, "time_s": times,
            "board_ids": None if ids is None else [str(b) for b in ids]}


def _cell_paths(values: np.ndarray) -> list[list[Cell]]:
    """Padded [A, L, 2] paths to lists of cells (rows with a negative entry end a path)."""
    out = []
    for agent in values:
        cells = []
        for i, j in agent.tolist():
            if i < 0 or j < 0:
                break
            cells.append((int(i), int(j)))
        out.append(cells)
    return out


def convert_rollouts(set_root: str | Path, config: str, split: str, solutions: str | Path,
                     out_runs: str | Path) -> dict:
    """Writes `out_runs/<board_id>/<k>.kicad_pcb` (+ `<k>.json` when the solutions carry
    `time_s`) for every row and rollout of the solutions file; nothing is written unless every
    rollout converts. Returns counts: boards, rollouts, agents, and agents connected (a path
    from start to target)."""
    arrays = _split_arrays(set_root, config, split)
    sol = load_solutions(solutions)
    ids = sol["board_ids"] or arrays["board_ids"][: len(sol["values"])]
    if len(ids) != len(sol["values"]):
        raise UserError(f"{solutions}: {len(ids)} board_ids for {len(sol['values'])} rows")
    row_of = {b: r for r, b in enumerate(arrays["board_ids"])}
    counts = {"boards": 0, "rollouts": 0, "agents": 0, "connected": 0}
    files: dict[Path, str] = {}
    for board_id, rollouts, times in zip(ids, sol["values"], _times(sol)):
        if board_id not in row_of:
            raise UserError(f"{solutions}: board {board_id!r} is not in {config}/{split}")
        row = row_of[board_id]
        starts, targets = arrays["starts"][row], arrays["targets"][row]
        for k, value in enumerate(rollouts):
            paths = (grid_to_paths(value, starts, targets) if sol["kind"] == "grids"
                     else _cell_paths(value))
            text = paths_to_board(board_dir(set_root, config, split, board_id),
                                  arrays["grid_size"], paths, starts, targets,
                                  uuid_seed=f"connector/{config}/{split}/{board_id}/{k}")
            folder = Path(out_runs) / board_id
            files[folder / f"{k}.kicad_pcb"] = text
            if times is not None:
                files[folder / f"{k}.json"] = json.dumps(
                    {"time_s": float(times[k]), "source": "connector"}, sort_keys=True)
            counts["rollouts"] += 1
            counts["agents"] += len(paths)
            counts["connected"] += sum(_connected(p, s, t)
                                       for p, s, t in zip(paths, starts, targets))
        counts["boards"] += 1
    _write(files)
    return counts


def _times(sol: dict) -> list:
    return [None] * len(sol["values"]) if sol["time_s"] is None else list(sol["time_s"])


def _connected(path: Sequence[Cell], start, target) -> bool:
    ends = {_cell(start), _cell(target)}
    return len(path) >= 2 and {path[0], path[-1]} == ends


def _write(files: dict[Path, str]) -> None:
    """Boards before their JSON: a rollout with its JSON is complete (as `pcbdata rollout`)."""
    for path in sorted(files, key=lambda p: (p.suffix == ".json", p)):
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, files[path])


def _split_arrays(set_root, config: str, split: str) -> dict:
    path = arrays_path(set_root, config, split)
    try:
        with np.load(path, allow_pickle=False) as data:
            return {"starts": data["starts"], "targets": data["targets"],
                    "board_ids": [str(b) for b in data["board_ids"]],
                    "grid_size": int(data["grid_size"])}
    except (OSError, KeyError, ValueError) as exc:
        raise UserError(f"{path}: no Connector arrays of {config}/{split} ({exc}); D1 sets "
                        f"export them") from None

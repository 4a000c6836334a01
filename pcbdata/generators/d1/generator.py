"""D1: synthetic grid boards, 5 two-pin nets, one routing layer (SPEC section 1)."""
from __future__ import annotations

from dataclasses import dataclass, field

from pcbdata.core.errors import GenerationError, UserError
from pcbdata.core.rng import Stream, check_seed
from pcbdata.generators.base import MIN_FEATURE_MM, Instance, board_id
from pcbdata.model.board import Board, Pad, Rules, Track, mm_to_nm
from pcbdata.model.connector import connector_arrays, npz_bytes

PLACEMENTS = ("uniform", "random-walk")
SIDE_NM = 100 * 1_000_000  # the lattice spans 100 mm whatever the grid size
VIA_DIAMETER_NM = mm_to_nm(0.6)
VIA_DRILL_NM = mm_to_nm(0.3)
_MAX_WALK_REDRAWS = 1000
# Pads, clearance and track width are half the pitch 100/G mm: the finest grid keeps them at
# the minimum copper feature (G = 5000: pitch 0.02 mm, pads 0.01 mm; checked in KiCad).
MAX_GRID = int(round(100 / (2 * MIN_FEATURE_MM)))


@dataclass(frozen=True)
class D1Params:
    grid: int
    placement: str = "uniform"  # one of PLACEMENTS
    n_nets: int = 5

    def __post_init__(self) -> None:
        if isinstance(self.grid, bool) or not isinstance(self.grid, int) or self.grid < 2:
            raise UserError(f"D1 grid size must be an integer >= 2, got {self.grid!r}")
        if self.grid > MAX_GRID:
            raise UserError(f"D1 grid size must be at most {MAX_GRID}, got {self.grid}: the "
                            f"pads and clearance (half the pitch, 100/G mm) would be smaller "
                            f"than {MIN_FEATURE_MM} mm")
        if self.placement not in PLACEMENTS:
            raise UserError(f"unknown D1 placement {self.placement!r}; choose one of "
                            f"{', '.join(PLACEMENTS)}")
        if isinstance(self.n_nets, bool) or not isinstance(self.n_nets, int) or self.n_nets < 1:
            raise UserError(f"D1 needs at least one net, got n_nets={self.n_nets}")
        if 2 * self.n_nets > self.grid * self.grid:
            raise UserError(f"D1 grid {self.grid} has {self.grid ** 2} cells, too few for "
                            f"{2 * self.n_nets} pads in distinct cells")

    @property
    def pitch_nm(self) -> int:
        return round(SIDE_NM / self.grid)

    def as_dict(self) -> dict:
        g = self.pitch_nm / 1e6
        return {"grid": self.grid, "placement": self.placement, "n_nets": self.n_nets,
                "pitch_mm": g, "pad_size_mm": g / 2, "clearance_mm": g / 2,
                "track_width_mm": g / 2, "edge_clearance_mm": g / 2,
                "via_diameter_mm": 0.6, "via_drill_mm": 0.3, "routing_layer": "F.Cu"}


Cell = tuple[int, int]


@dataclass
class GridInstance(Instance):
    """A D1 instance: also, per net, its (start cell, target cell) as (i, j); the pad of cell
    (i, j) is centred at ((i + 0.75) g, (j + 0.75) g)."""

    cells: list[tuple[Cell, Cell]] = field(default_factory=list)


class D1Generator:
    """Grid boards of `params.n_nets` two-pin nets on a G x G lattice (`Generator`,
    `SplitArrays`: the Connector arrays of each split).

    Guarantee: pads sit in distinct cells; the board loads in KiCad 9.0.8 and its DRC reports
    only the `n_nets` unconnected items. With `random-walk` placement every instance also has a
    reference routing (the walks) that is DRC-clean and fully connected.
    `connector_version` (the preset's) is recorded in the arrays; it is needed to export them.
    """

    family = "d1"
    seed_key = 1
    routing_layers = 1

    def __init__(self, params: D1Params, connector_version: str | None = None):
        self.params = params
        self.connector_version = connector_version
        g = params.pitch_nm
        self.rules = Rules(clearance=g // 2, track_width=g // 2, edge_clearance=g // 2,
                           via_diameter=VIA_DIAMETER_NM, via_drill=VIA_DRILL_NM,
                           single_layer="F.Cu")

    def cell_centre(self, i: int, j: int) -> tuple[int, int]:
        g = self.params.pitch_nm
        return round((4 * i + 3) * g / 4), round((4 * j + 3) * g / 4)

    def generate(self, seed: int, split: str, index: int) -> GridInstance:
        check_seed(seed)
        stream = Stream(seed, self.seed_key, self.params.grid, split, index)
        if self.params.placement == "uniform":
            cells, walks = self._uniform_cells(stream), None
        else:
            cells, walks = self._random_walk_cells(stream)
        key = f"d1/{self.params.grid}/{self.params.placement}/{seed}/{split}/{index}"
        board = self._board(cells, key, walks=None)
        reference = self._board(cells, key, walks=walks) if walks is not None else None
        return GridInstance(board_id=board_id(index), board=board, reference=reference,
                            cells=cells)

    def array_row(self, instance: Instance) -> list:
        assert isinstance(instance, GridInstance)
        return instance.cells

    def split_arrays(self, board_ids: list[str], rows: list) -> bytes:
        if self.connector_version is None:
            raise ValueError("D1Generator(connector_version=...) is needed to export arrays")
        return npz_bytes(connector_arrays(board_ids, rows, self.params.grid,
                                          self.connector_version))

    def _uniform_cells(self, stream: Stream):
        grid = self.params.grid
        drawn: list[tuple[int, int]] = []
        taken: set[int] = set()
        while len(drawn) < 2 * self.params.n_nets:
            cell = stream.integer(grid * grid)
            if cell not in taken:
                taken.add(cell)
                drawn.append(divmod(cell, grid))
        return [(drawn[2 * k], drawn[2 * k + 1]) for k in range(self.params.n_nets)]

    def _random_walk_cells(self, stream: Stream):
        """Jumanji Connector-v2 placement: uniform starts, then simultaneous self-avoiding walks."""
        grid, n = self.params.grid, self.params.n_nets
        for _ in range(_MAX_WALK_REDRAWS):
            occupied: set[tuple[int, int]] = set()
            walks: list[list[tuple[int, int]]] = []
            while len(walks) < n:
                cell = divmod(stream.integer(grid * grid), grid)
                if cell not in occupied:
                    occupied.add(cell)
                    walks.append([cell])
            active = list(range(n))
            while active:
                still = []
                for k in active:
                    i, j = walks[k][-1]
                    moves = [(a, b) for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1))
                             if 0 <= a < grid and 0 <= b < grid and (a, b) not in occupied]
                    if moves:
                        step = stream.choice(moves)
                        occupied.add(step)
                        walks[k].append(step)
                        still.append(k)
                active = still
            if all(len(w) >= 2 for w in walks):  # a net needs two distinct pads
                return [(w[0], w[-1]) for w in walks], walks
        raise GenerationError(f"random-walk placement on grid {grid}: no walk set with "
                              f"{n} non-empty walks after {_MAX_WALK_REDRAWS} draws")

    def _board(self, cells, key: str, walks) -> Board:
        g = self.params.pitch_nm
        pads, tracks = [], []
        for k, (start, target) in enumerate(cells, start=1):
            for cell in (start, target):
                x, y = self.cell_centre(*cell)
                pads.append(Pad(x=x, y=y, net=f"NET{k}", kind="smd_rect", size=g // 2))
            if walks is not None:
                tracks += self._walk_tracks(walks[k - 1], f"NET{k}")
        side = SIDE_NM + g // 2
        return Board(width=side, height=side, rules=self.rules, pads=pads, tracks=tracks,
                     uuid_seed=key + ("/reference" if walks is not None else ""))

    def _walk_tracks(self, walk, net: str) -> list[Track]:
        """One track segment per straight run of the walk, through the cell centres."""
        corners = [walk[0]]
        for prev, cur, nxt in zip(walk, walk[1:], walk[2:]):
            if (cur[0] - prev[0], cur[1] - prev[1]) != (nxt[0] - cur[0], nxt[1] - cur[1]):
                corners.append(cur)
        corners.append(walk[-1])
        width = self.rules.track_width
        out = []
        for a, b in zip(corners, corners[1:]):
            (x1, y1), (x2, y2) = self.cell_centre(*a), self.cell_centre(*b)
            out.append(Track(x1, y1, x2, y2, width, net))
        return out

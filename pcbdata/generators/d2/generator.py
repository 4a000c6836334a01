"""D2: synthetic gridless two-layer boards with multi-pin nets (SPEC section 2)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from pcbdata.core.errors import GenerationError, UserError
from pcbdata.core.rng import Stream, check_seed
from pcbdata.generators.base import (
    KICAD_HOLE_CLEARANCE_MM,
    KICAD_MIN_ANNULAR_MM,
    MAX_LENGTH_MM,
    MIN_FEATURE_MM,
    Instance,
    board_id,
)
from pcbdata.generators.params import GeneratorParams
from pcbdata.model.board import Board, CopperLayer, Pad, PadKind, Rules, mm_to_nm

_ATTEMPTS_PER_PAD = 500
_PLACEMENT_RESTARTS = 10
# Random sequential placement saturates near 55 % of the hexagonal packing density; asking
# for more than this share of the hexagonal bound is rejected up front instead of retried.
_FILL_LIMIT = 0.5
# Lengths that are copper features, holes, clearances or the placement lattice.
_FEATURES = ("pad_size_mm", "drill_mm", "lattice_mm", "min_pad_spacing_mm", "clearance_mm",
             "track_width_mm", "via_diameter_mm", "via_drill_mm")


def _short(value: float, needed: float) -> bool:
    """`value` < `needed`, ignoring float noise below a nanometre (0.85 - 0.8 is 0.05)."""
    return value < needed - 1e-7


@dataclass(frozen=True)
class D2Params(GeneratorParams):
    width_mm: tuple[float, float] = (80.0, 120.0)
    height_mm: tuple[float, float] = (80.0, 120.0)
    net_counts: tuple[int, ...] = (4, 5, 6)
    pads_per_net: dict[str, float] = field(
        default_factory=lambda: {"2": 0.6, "3": 0.2, "4": 0.1, "5": 0.1})
    pad_size_mm: float = 2.4
    through_hole_fraction: float = 0.3
    drill_mm: float = 0.6
    roundrect_ratio: float = 0.25
    lattice_mm: float = 0.6
    placement_fraction: float = 0.9
    min_pad_spacing_mm: float = 4.8
    clearance_mm: float = 0.3
    track_width_mm: float = 0.3
    edge_clearance_mm: float = 0.3
    via_diameter_mm: float = 1.2
    via_drill_mm: float = 0.6

    LABEL = "D2"

    @staticmethod
    def coerce(key: str, value, annotation: str, where: str):
        return _coerce(key, value, annotation, where)

    def __post_init__(self) -> None:
        problems = self._problems()
        if problems:
            raise UserError("invalid D2 parameters: " + "; ".join(problems))

    def _problems(self) -> list[str]:
        """Why these parameters cannot give boards that pass their KiCad check (empty: they
        can). Stages: finite numbers, then each value's own range, then how they combine."""
        return (self._non_finite() or self._ranges() or self._lengths()
                or self._combinations() or self._placement())

    def _numbers(self):
        """(name, value) of every number, list items and table values included."""
        for f in fields(self):
            value = getattr(self, f.name)
            items = value.values() if isinstance(value, dict) else (
                value if isinstance(value, tuple) else [value])
            for item in items:
                yield f.name, item

    def _non_finite(self) -> list[str]:
        return [f"{name} must be finite, got {value}" for name, value in self._numbers()
                if isinstance(value, float) and not math.isfinite(value)]

    def _ranges(self) -> list[str]:
        out = []
        for name in ("width_mm", "height_mm"):
            low, high = getattr(self, name)
            if not 0 < low <= high <= MAX_LENGTH_MM:
                out.append(f"{name} must be a range [low, high] with 0 < low <= high <= "
                           f"{MAX_LENGTH_MM:g} (KiCad holds coordinates up to about 2147 mm), "
                           f"got {[low, high]}")
        if not self.net_counts or min(self.net_counts) < 1:
            out.append(f"net_counts must list net counts >= 1, got {list(self.net_counts)}")
        if not self.pads_per_net:
            out.append("pads_per_net must not be empty")
        for k, p in self.pads_per_net.items():
            if int(k) < 2 or p < 0:
                out.append(f"pads_per_net: a net has >= 2 pads with probability >= 0, got {k}: {p}")
        if self.pads_per_net and abs(math.fsum(self.pads_per_net.values()) - 1) > 1e-9:
            total = math.fsum(self.pads_per_net.values())
            out.append(f"pads_per_net probabilities must sum to 1, got {total:g}")
        if not 0 <= self.through_hole_fraction <= 1:
            out.append(f"through_hole_fraction must be in [0, 1], got {self.through_hole_fraction}")
        if not 0 <= self.roundrect_ratio <= 0.5:
            out.append(f"roundrect_ratio must be in [0, 0.5], got {self.roundrect_ratio}")
        if not 0 < self.placement_fraction <= 1:
            out.append(f"placement_fraction must be in (0, 1], got {self.placement_fraction}")
        return out

    def _lengths(self) -> list[str]:
        """Every length within what KiCad holds; features and clearances not below the
        finest a board can be made with (the edge clearance may be 0)."""
        out = []
        for name in _FEATURES + ("edge_clearance_mm",):
            value = getattr(self, name)
            low = 0.0 if name == "edge_clearance_mm" else MIN_FEATURE_MM
            if not low <= value <= MAX_LENGTH_MM:
                out.append(f"{name} must be from {low:g} to {MAX_LENGTH_MM:g} mm, got {value}")
        return out

    def _combinations(self) -> list[str]:
        out = []
        if self.drill_mm >= self.pad_size_mm:
            out.append("drill_mm must be smaller than pad_size_mm")
        if self.via_drill_mm >= self.via_diameter_mm:
            out.append("via_drill_mm must be smaller than via_diameter_mm")
        if out:
            return out
        if _short(self.via_diameter_mm - self.via_drill_mm, 2 * KICAD_MIN_ANNULAR_MM):
            out.append(f"vias {self.via_diameter_mm}/{self.via_drill_mm} mm leave an annular "
                       f"ring under KiCad's minimum {KICAD_MIN_ANNULAR_MM} mm")
        if self.through_hole_fraction > 0:
            out += self._hole_problems()
        gap = self.min_pad_spacing_mm - 2 * self._reach(smd=self.through_hole_fraction < 1)
        if _short(gap, self.clearance_mm):
            out.append(f"pads {self.min_pad_spacing_mm} mm apart leave {gap:.4g} mm between "
                       f"pads at worst (corner to corner), less than the clearance "
                       f"{self.clearance_mm}")
        return out

    def _hole_problems(self) -> list[str]:
        out = []
        if _short(self.pad_size_mm - self.drill_mm, 2 * KICAD_MIN_ANNULAR_MM):
            out.append(f"through-hole pads {self.pad_size_mm}/{self.drill_mm} mm leave an annular "
                       f"ring under KiCad's minimum {KICAD_MIN_ANNULAR_MM} mm")
        # KiCad holds pad holes to the project's minimum hole, the via drill (kicad_writer).
        if _short(self.drill_mm, self.via_drill_mm):
            out.append(f"drill_mm {self.drill_mm} is below the projects' minimum hole size "
                       f"{self.via_drill_mm:g} mm (via_drill_mm, which KiCad also applies to "
                       f"pad holes)")
        hole_gap = self.min_pad_spacing_mm - self.drill_mm / 2 - self._reach(
            smd=self.through_hole_fraction < 1)
        if _short(hole_gap, KICAD_HOLE_CLEARANCE_MM):
            out.append(f"pads {self.min_pad_spacing_mm} mm apart leave {hole_gap:.4g} mm from a "
                       f"hole to the next pad, under KiCad's hole clearance "
                       f"{KICAD_HOLE_CLEARANCE_MM} mm")
        return out

    def _reach(self, smd: bool) -> float:
        """How far a pad's copper reaches from its centre towards a neighbour, at worst: the
        pad radius, or for a rounded square along its diagonal."""
        radius = self.pad_size_mm / 2
        if not smd:
            return radius
        corner = self.roundrect_ratio * self.pad_size_mm
        return max(radius, self.pad_size_mm / math.sqrt(2) - (math.sqrt(2) - 1) * corner)

    def _placement(self) -> list[str]:
        out = []
        margin = (1 - self.placement_fraction) / 2 * min(self.width_mm[0], self.height_mm[0])
        if margin - self.pad_size_mm / 2 < self.edge_clearance_mm:
            out.append(f"pads at the edge of the central {self.placement_fraction:.0%} would be "
                       f"closer than {self.edge_clearance_mm} mm to the board edge")
        capacity = min(self.placement_capacity(), self.lattice_positions())
        if self.max_pads > capacity:
            out.append(f"up to {self.max_pads} pads per board, but the smallest placement area "
                       f"holds about {capacity} pads {self.min_pad_spacing_mm} mm apart on the "
                       f"{self.lattice_mm} mm lattice by random placement; use fewer nets or "
                       f"pads, a bigger board, a smaller spacing or a finer lattice")
        return out

    def lattice_positions(self) -> int:
        """Lattice points the smallest placement area is sure to hold."""
        lattice = mm_to_nm(self.lattice_mm)
        a = self.placement_fraction * mm_to_nm(self.width_mm[0])
        b = self.placement_fraction * mm_to_nm(self.height_mm[0])
        return int(a // lattice) * int(b // lattice)

    @property
    def max_pads(self) -> int:
        return max(self.net_counts) * max(int(k) for k, p in self.pads_per_net.items() if p > 0)

    def placement_capacity(self) -> int:
        s = self.min_pad_spacing_mm
        a = self.placement_fraction * self.width_mm[0]
        b = self.placement_fraction * self.height_mm[0]
        return int(_FILL_LIMIT * (a + s) * (b + s) / (s * s * math.sqrt(3) / 2))



def _coerce(key: str, value, annotation: str, where: str):
    def bad(expected: str):
        shown = repr(value) if len(repr(value)) <= 80 else repr(value)[:77] + "..."
        return UserError(f"{where}: D2 parameter {key!r} must be {expected}, got {shown}")

    def number(v):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise bad("a number" if "tuple" not in annotation else "a list of numbers")
        try:
            out = float(v)
        except OverflowError:  # an integer beyond any float
            out = math.inf
        if not math.isfinite(out):
            raise bad("finite (nan and inf are not sizes or probabilities)")
        return out

    if annotation == "float":
        return number(value)
    if annotation == "tuple[float, float]":
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            raise bad("a range [low, high]")
        return (number(value[0]), number(value[1]))
    if annotation == "tuple[int, ...]":
        if not isinstance(value, (list, tuple)) or not all(
                isinstance(v, int) and not isinstance(v, bool) for v in value):
            raise bad("a list of integers")
        return tuple(value)
    if annotation == "dict[str, float]":
        if not isinstance(value, dict):
            raise bad("a table {pads = probability, ...}, e.g. {2 = 0.5, 3 = 0.5}")
        out = {}
        for k, v in value.items():
            if not str(k).isdigit():
                raise bad("a table keyed by pad counts")
            out[str(int(k))] = number(v)
        return dict(sorted(out.items(), key=lambda kv: int(kv[0])))
    raise AssertionError(annotation)


class D2Generator:
    """Gridless two-layer boards with multi-pin nets.

    Guarantee: pad centres lie on the lattice inside the central placement area, at least
    `min_pad_spacing_mm` apart; the board loads in KiCad 9.0.8 and its DRC reports only
    unconnected items (sum over nets of pads - 1). Parameters that cannot be placed are
    rejected when the generator is made; a board that still fails raises GenerationError.
    """

    family = "d2"
    seed_key = 2
    routing_layers = 2

    def __init__(self, params: D2Params):
        self.params = params
        p = params
        self.rules = Rules(clearance=mm_to_nm(p.clearance_mm),
                           track_width=mm_to_nm(p.track_width_mm),
                           edge_clearance=mm_to_nm(p.edge_clearance_mm),
                           via_diameter=mm_to_nm(p.via_diameter_mm),
                           via_drill=mm_to_nm(p.via_drill_mm))
        self._pad_counts = [int(k) for k in p.pads_per_net]
        self._pad_weights = list(p.pads_per_net.values())

    def generate(self, seed: int, split: str, index: int) -> Instance:
        p = self.params
        check_seed(seed)
        stream = Stream(seed, self.seed_key, 0, split, index)
        # Sides are kept to the micrometre so that files stay short and exact.
        width = mm_to_nm(round(stream.uniform(*p.width_mm), 3))
        height = mm_to_nm(round(stream.uniform(*p.height_mm), 3))
        n_nets = stream.choice(p.net_counts)
        sizes = [stream.weighted(self._pad_counts, self._pad_weights) for _ in range(n_nets)]
        kinds: list[tuple[PadKind, CopperLayer]] = []
        for _ in range(sum(sizes)):
            if stream.random() < p.through_hole_fraction:
                kinds.append(("thru_round", "F.Cu"))
            else:
                kinds.append(("smd_roundrect", "F.Cu" if stream.random() < 0.5 else "B.Cu"))
        positions = self._place(stream, width, height, len(kinds), split, index)
        nets = [f"NET{k}" for k, size in enumerate(sizes, start=1) for _ in range(size)]
        size_nm, drill = mm_to_nm(p.pad_size_mm), mm_to_nm(p.drill_mm)
        pads = [Pad(x=x, y=y, net=net, kind=kind, size=size_nm, layer=layer,
                    drill=drill if kind == "thru_round" else 0, roundrect_ratio=p.roundrect_ratio)
                for (x, y), net, (kind, layer) in zip(positions, nets, kinds)]
        board = Board(width=width, height=height, rules=self.rules, pads=pads,
                      uuid_seed=f"d2/{seed}/{split}/{index}")
        return Instance(board_id=board_id(index), board=board)

    def _place(self, stream: Stream, width: int, height: int, count: int, split: str, index: int):
        p = self.params
        lattice = mm_to_nm(p.lattice_mm)
        margin = (1 - p.placement_fraction) / 2
        lo_x = math.ceil(margin * width / lattice)
        hi_x = math.floor((1 - margin) * width / lattice)
        lo_y = math.ceil(margin * height / lattice)
        hi_y = math.floor((1 - margin) * height / lattice)
        nx, ny = hi_x - lo_x + 1, hi_y - lo_y + 1
        min_sq = mm_to_nm(p.min_pad_spacing_mm) ** 2
        for _ in range(_PLACEMENT_RESTARTS):
            placed: list[tuple[int, int]] = []
            while len(placed) < count:
                for _ in range(_ATTEMPTS_PER_PAD):
                    x = (lo_x + stream.integer(nx)) * lattice
                    y = (lo_y + stream.integer(ny)) * lattice
                    if all((x - a) ** 2 + (y - b) ** 2 >= min_sq for a, b in placed):
                        placed.append((x, y))
                        break
                else:
                    break
            if len(placed) == count:
                return placed
        raise GenerationError(
            f"d2 {split} board {index}: could not place {count} pads {p.min_pad_spacing_mm} mm "
            f"apart on a {width / 1e6:g} x {height / 1e6:g} mm board after {_PLACEMENT_RESTARTS} "
            f"tries; parameters: {p.as_dict()}")

"""Plain-data board model for generated boards.

Coordinates and sizes are integer nanometres (KiCad's internal unit), so that boards are
exact and their files byte-identical across runs and machines.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

NM_PER_MM = 1_000_000

PadKind = Literal["smd_rect", "smd_roundrect", "thru_round"]
CopperLayer = Literal["F.Cu", "B.Cu"]
Side = Literal["F", "B"]
PadShape = Literal["rect", "roundrect", "circle", "oval"]


def mm_to_nm(value_mm: float) -> int:
    return int(round(value_mm * NM_PER_MM))


def nm_to_mm(value_nm: int) -> float:
    return value_nm / NM_PER_MM


@dataclass(frozen=True)
class Pad:
    """One pad; a generated board puts each pad in a one-pad footprint of its own."""

    x: int
    y: int
    net: str
    kind: PadKind
    size: int
    layer: CopperLayer = "F.Cu"  # SMD pads only; through-hole pads span every copper layer
    drill: int = 0
    roundrect_ratio: float = 0.25


@dataclass(frozen=True)
class Track:
    x1: int
    y1: int
    x2: int
    y2: int
    width: int
    net: str
    layer: CopperLayer = "F.Cu"


@dataclass(frozen=True)
class Arc:
    """A track arc through three points (KiCad stores start, mid and end)."""

    x1: int
    y1: int
    xm: int
    ym: int
    x2: int
    y2: int
    width: int
    net: str
    layer: CopperLayer = "F.Cu"


@dataclass(frozen=True)
class Via:
    x: int
    y: int
    diameter: int
    drill: int
    net: str


@dataclass(frozen=True)
class Rules:
    clearance: int
    track_width: int
    edge_clearance: int
    via_diameter: int
    via_drill: int
    single_layer: CopperLayer | None = None  # D1: routing allowed on this copper layer only


@dataclass(frozen=True)
class PartPad:
    """One pad of a multi-pad part, in the part's own frame (before rotation and side).

    `drill` > 0 makes it a through-hole pad, plated unless `plated` is False (a mounting hole:
    then the pad is the bare hole). An empty `net` is an unconnected pin."""

    number: str
    dx: int
    dy: int
    shape: PadShape
    width: int
    height: int
    net: str = ""
    drill: int = 0
    plated: bool = True
    roundrect_ratio: float = 0.25


@dataclass(frozen=True)
class Part:
    """A footprint with several pads (or a mounting hole), placed at (x, y), turned by
    `rotation` degrees (a multiple of 90, counter-clockwise as KiCad turns) on side `side`.
    `courtyard` is (half width, half height) around the origin in the part's own frame."""

    ref: str
    name: str
    x: int
    y: int
    pads: tuple[PartPad, ...]
    courtyard: tuple[int, int]
    rotation: int = 0
    side: Side = "F"

    @property
    def through_hole(self) -> bool:
        return any(pad.drill > 0 for pad in self.pads)

    def local_to_board(self, dx: int, dy: int) -> tuple[int, int]:
        """Board coordinates of a point of the part's frame: mirrored left-right on the back
        side (as KiCad flips), then turned (y grows downwards, so +90 maps +x to -y)."""
        if self.side == "B":
            dx = -dx
        turns = (self.rotation // 90) % 4
        for _ in range(turns):
            dx, dy = dy, -dx
        return self.x + dx, self.y + dy


@dataclass(frozen=True)
class NetClass:
    """A net class: its nets follow its own clearance, track width and via size."""

    name: str
    clearance: int
    track_width: int
    via_diameter: int
    via_drill: int
    nets: tuple[str, ...] = ()


@dataclass(frozen=True)
class EdgeLine:
    x1: int
    y1: int
    x2: int
    y2: int


@dataclass(frozen=True)
class EdgeArc:
    """An outline arc through three points."""

    x1: int
    y1: int
    xm: int
    ym: int
    x2: int
    y2: int


@dataclass
class Board:
    width: int
    height: int
    rules: Rules
    pads: list[Pad]
    tracks: list[Track] = field(default_factory=list)
    vias: list[Via] = field(default_factory=list)
    arcs: list[Arc] = field(default_factory=list)
    uuid_seed: str = ""  # makes item UUIDs deterministic per board
    # Realistic boards only; the defaults keep the one-pad-footprint boards' files unchanged.
    parts: list[Part] = field(default_factory=list)
    copper_layers: int = 2
    outline: tuple[EdgeLine | EdgeArc, ...] = ()  # empty: the rectangle width x height
    net_classes: tuple[NetClass, ...] = ()  # besides `Default` (which `rules` describes)

    def _pad_nets(self) -> list[str]:
        """The net of every connected pad: one-pad footprints, then parts' pads."""
        nets = [p.net for p in self.pads]
        nets += [pad.net for part in self.parts for pad in part.pads if pad.net]
        return nets

    def _net_sizes(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        for net in self._pad_nets():
            counts[net] = counts.get(net, 0) + 1
        return counts

    @property
    def net_names(self) -> list[str]:
        """Net names in first-appearance order of the pads."""
        return list(dict.fromkeys(self._pad_nets()))

    @property
    def n_pads(self) -> int:
        """Terminal pads: pads whose net has at least two pads (SPEC section 0)."""
        return sum(c for c in self._net_sizes().values() if c >= 2)

    @property
    def n_components(self) -> int:
        return len(self.pads) + len(self.parts)

    @property
    def missing_connections(self) -> int:
        """Ratsnest edges of the bare board: pads minus one, per net."""
        return sum(c - 1 for c in self._net_sizes().values())

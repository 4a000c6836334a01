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

    @property
    def net_names(self) -> list[str]:
        """Net names in first-appearance order of the pads."""
        return list(dict.fromkeys(p.net for p in self.pads))

    @property
    def n_pads(self) -> int:
        """Terminal pads: pads whose net has at least two pads (SPEC section 0)."""
        counts: dict[str, int] = {}
        for pad in self.pads:
            counts[pad.net] = counts.get(pad.net, 0) + 1
        return sum(c for c in counts.values() if c >= 2)

    @property
    def missing_connections(self) -> int:
        """Ratsnest edges of the bare board: pads minus one, per net."""
        counts: dict[str, int] = {}
        for pad in self.pads:
            counts[pad.net] = counts.get(pad.net, 0) + 1
        return sum(c - 1 for c in counts.values())

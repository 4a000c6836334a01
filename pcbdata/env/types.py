"""Plain data of the routing environment: action and mode orders, phases, candidates, and
the instance's static board as the KiCad session reports it (integer nanometres)."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

#: Action types, in the order of the action's `type` index (SPEC section 6).
ACTION_TYPES = ("idle", "net_select", "net_end", "start_route", "make_line", "make_via", "finish")
IDLE, NET_SELECT, NET_END, START_ROUTE, MAKE_LINE, MAKE_VIA, FINISH = range(7)
#: Routing modes, in the order of the action's `mode` index.
MODES = ("walkaround", "mark_obstacles", "push_n_shove")
WALKAROUND, MARK_OBSTACLES, PUSH_N_SHOVE = range(3)
#: Phases of the phase machine (observation `router_head.phase`).
PHASES = ("no_net", "net", "routing")
NO_NET, NET, ROUTING = range(3)
#: Kinds of candidate points (observation column `kind`); 0 marks an empty slot.
CANDIDATE_KINDS = ("empty", "ring", "pad", "via", "track_end")
EMPTY, RING, PAD, VIA, TRACK_END = range(5)

#: Who computes what (also in every step's `info["engine"]`).
ENGINE = {
    "board_model": "kicad", "tracks_and_vias": "kicad", "connectivity": "kicad",
    "drc": "kicad", "saving": "kicad",
    "walkaround": "pcbdata", "mark_obstacles": "pcbdata", "finish": "pcbdata",
    "candidates": "pcbdata", "masks": "pcbdata", "push_n_shove": "pcbdata",
}

Point = tuple[int, int]


@dataclass(frozen=True)
class Candidate:
    x: int
    y: int
    layer: int  # index into StaticBoard.layers
    kind: int  # one of CANDIDATE_KINDS


@dataclass(frozen=True)
class Head:
    x: int
    y: int
    layer: int


@dataclass(frozen=True)
class NetRules:
    name: str
    clearance: int
    track_width: int
    via_diameter: int
    via_drill: int


@dataclass(frozen=True)
class PadInfo:
    net: str
    x: int
    y: int
    size: tuple[int, int]
    shape: str
    layers: tuple[int, ...]  # layer indices
    drill: int
    name: str
    polygons: dict = field(default_factory=dict, compare=False)  # layer name -> rings
    clearance: int = 0  # the pad's (or its footprint's) clearance override, 0 if none


@dataclass(frozen=True)
class StaticBoard:
    """What does not change during an episode."""

    board_id: str
    layers: tuple[str, ...]
    outline: tuple[tuple[Point, ...], ...]
    nets: tuple[NetRules, ...]  # every net with a pad, in KiCad netcode order (action index)
    pads: tuple[PadInfo, ...]
    zones: tuple[dict, ...]
    graphics: tuple[dict, ...]  # copper drawings and texts: {"net", "layer", "polygon"}
    net_count: int
    edge_clearance: int
    grid_pitch: int | None  # D1: lattice pitch (nm)
    grid_origin: int | None  # D1: lattice offset (nm), pad centres at origin + k * pitch
    #: The board setup's hole clearance (nm): copper of other nets keeps this far from a hole.
    hole_clearance: int = 0

    def net_index(self, name: str) -> int:
        try:
            return self._indices[0][name]
        except KeyError:
            raise KeyError(f"board {self.board_id}: no net {name!r}") from None

    def pads_of(self, net: str) -> list[int]:
        return list(self._indices[1].get(net, ()))

    @cached_property
    def _indices(self) -> tuple[dict[str, int], dict[str, tuple[int, ...]]]:
        """Net name -> action index (the first net of that name), and net name -> its pads'
        indices; built once per board (observations ask for them at every step)."""
        nets: dict[str, int] = {}
        for i, net in enumerate(self.nets):
            nets.setdefault(net.name, i)
        pads: dict[str, list[int]] = {}
        for i, pad in enumerate(self.pads):
            pads.setdefault(pad.net, []).append(i)
        return nets, {k: tuple(v) for k, v in pads.items()}


@dataclass(frozen=True)
class BoardView:
    """A read-only plain-data view of the board as pcbdata's router sees it
    (`RoutingEnv.board_view`): the static board, every piece of copper (pads, zones, drawings,
    tracks, vias; `pcbdata.router.geometry.BoardGeometry`) and the copper cluster of each pad
    (KiCad's connectivity: pads of a net in one cluster are joined). For agents that plan; all
    copper still reaches KiCad through actions."""

    static: StaticBoard
    geometry: object  # pcbdata.router.geometry.BoardGeometry
    pad_cluster: tuple[int, ...]  # per pad of `static.pads`

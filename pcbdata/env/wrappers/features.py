"""Entity features of the RL wrapper (`pcbdata.env.wrappers.rl`): the environment's nested
observation as one fixed-size table, one row per entity, for standard RL libraries.

Rows come in fixed blocks, one per entity family (`FAMILIES`, sizes from the environment's
capacities); each row is `COLUMNS` (float32), with the family id in `entity_type`, up to two
net indices in `entity_net` (-1: none) and 1 in `entity_mask` when the row holds an entity.
Positions are relative to the centre of the board outline's bounding box, divided by half its
larger side (the board spans [-1, 1] on that side, aspect kept); sizes are divided by the same
scale; layers are the copper layer's index over (layers - 1): F.Cu 0, B.Cu 1. So every feature
is the same when the whole board is moved. Pure numpy over the raw observation: no KiCad.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Entity families in block order (their index is the `entity_type` id).
FAMILIES = ("board", "edge", "net", "pad", "track", "via", "ratsnest", "head", "candidate",
            "violation")
BOARD, EDGE, NET, PAD, TRACK, VIA, RATSNEST, HEAD, CANDIDATE, VIOLATION = range(len(FAMILIES))
#: Feature columns; what each family puts in them is the table in docs/env_rl.md.
COLUMNS = ("x1", "y1", "x2", "y2", "size1", "size2", "size3", "size4", "layer_lo", "layer_hi",
           "code", "a", "b", "count")
X1, Y1, X2, Y2, S1, S2, S3, S4, LAYER_LO, LAYER_HI, CODE, A, B, COUNT = range(len(COLUMNS))
SIZE_COLUMNS = (S1, S2, S3, S4)
POSITION_COLUMNS = (X1, Y1, X2, Y2)


@dataclass(frozen=True)
class Layout:
    """Row blocks of the entity table: family -> (first row, rows)."""

    blocks: tuple[tuple[int, int], ...]

    @classmethod
    def from_options(cls, o) -> Layout:
        sizes = (1, o.max_outline_points, o.max_nets, o.max_pads, o.max_tracks, o.max_vias,
                 o.max_ratsnest, 1, o.max_candidates, o.max_violations)
        starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
        return cls(tuple((int(s), int(n)) for s, n in zip(starts, sizes, strict=True)))

    @property
    def rows(self) -> int:
        start, size = self.blocks[-1]
        return start + size

    def block(self, family: int) -> slice:
        start, size = self.blocks[family]
        return slice(start, start + size)

    def types(self) -> np.ndarray:
        return np.repeat(np.arange(len(FAMILIES), dtype=np.int64), [n for _, n in self.blocks])


@dataclass(frozen=True)
class Frame:
    """The board's frame: centre (mm) and scale (mm per unit), and the layer divisor."""

    cx: float
    cy: float
    scale: float
    layer_span: float

    def x(self, v):
        return (np.asarray(v, dtype=np.float64) - self.cx) / self.scale

    def y(self, v):
        return (np.asarray(v, dtype=np.float64) - self.cy) / self.scale

    def size(self, v):
        return np.asarray(v, dtype=np.float64) / self.scale

    def layer(self, v):
        v = np.asarray(v, dtype=np.float64)
        return np.where(v < 0, -1.0, v / self.layer_span)


def frame_of(static: dict) -> Frame:
    """Bounding box of the outline's points (the pads' when there is no outline)."""
    points = static["outline"][: int(static["outline_count"]), :2]
    if not len(points):
        pads = static["pads"]
        points = pads[pads[:, 0] == 1, 2:4]
    if not len(points):
        points = np.zeros((1, 2))
    low, high = points.min(axis=0), points.max(axis=0)
    half = float(max(high - low)) / 2
    return Frame(cx=float(low[0] + high[0]) / 2, cy=float(low[1] + high[1]) / 2,
                 scale=half if half > 0 else 1.0,
                 layer_span=float(max(int(static["n_layers"]) - 1, 1)))


def _put(table: np.ndarray, nets: np.ndarray, block: slice, columns: dict[int, object],
         net_a=None, net_b=None) -> None:
    """Writes a family's columns (arrays of the block's length, or scalars) into its block;
    rows without an entity are cleared afterwards by `entity_table`."""
    for column, values in columns.items():
        table[block, column] = values
    if net_a is not None:
        nets[block, 0] = net_a
    if net_b is not None:
        nets[block, 1] = net_b


@dataclass(frozen=True)
class StaticRows:
    """The rows that do not change during an episode (edges, nets, pads) and the frame."""

    table: np.ndarray
    nets: np.ndarray
    valid: np.ndarray
    frame: Frame


def static_rows(raw: dict, layout: Layout) -> StaticRows:
    """Computed once per episode (at reset): `entity_table` starts from copies of them."""
    table = np.zeros((layout.rows, len(COLUMNS)), dtype=np.float64)
    nets = np.full((layout.rows, 2), -1, dtype=np.int64)
    valid = np.zeros(layout.rows, dtype=np.int8)
    frame = frame_of(raw["board_static"])
    for fill in (_edges, _net_rules, _pad_shapes):
        fill(raw, frame, layout, table, nets, valid)
    return StaticRows(table, nets, valid, frame)


def entity_table(raw: dict, masks: dict, layout: Layout, max_steps: int,
                 static: StaticRows | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, Frame]:
    """(features float32 [rows, COLUMNS], nets int64 [rows, 2], valid int8 [rows], frame) of
    a raw observation and the environment's per-argument masks; `static`: the episode's
    `static_rows` (computed here when not given)."""
    static = static or static_rows(raw, layout)
    table, nets, valid = static.table.copy(), static.nets.copy(), static.valid.copy()
    frame = static.frame
    _board(raw, frame, layout, table, nets, valid, max_steps)
    _net_state(raw, masks, layout, table)
    _pad_state(raw, layout, table)
    for fill in (_tracks, _vias, _ratsnest, _head, _violations):
        fill(raw, frame, layout, table, nets, valid)
    _candidates(raw, masks, frame, layout, table, nets, valid)
    table[valid == 0] = 0.0  # padding rows are all zeros, whatever the board's frame
    nets[valid == 0] = -1
    return table.astype(np.float32), nets, valid, frame


def _board(raw, f, layout, table, nets, valid, max_steps):
    s, g = raw["board_static"], raw["routing_geometry"]
    points = s["outline"][: int(s["outline_count"]), :2]
    low = points.min(axis=0) if len(points) else np.array([f.cx, f.cy])
    high = points.max(axis=0) if len(points) else np.array([f.cx, f.cy])
    half_w = f.size((high - low) / 2)
    rules = s["rules"]  # clearance, track width, via diameter, via drill, edge clearance
    row = layout.block(BOARD).start
    table[row] = (-half_w[0], -half_w[1], half_w[0], half_w[1], f.size(rules[4]),
                  f.size(rules[0]), f.size(rules[1]), f.size(rules[2]), 0.0, 1.0,
                  float(s["n_layers"]), float(raw["drc"]["total"]),
                  float(raw["step"]) / max_steps, float(g["unconnected"]))
    valid[row] = 1


def _edges(raw, f, layout, table, nets, valid):
    """One edge per outline point: to the next point of its ring (the last closes the ring)."""
    outline = raw["board_static"]["outline"]  # x, y, ring
    n = int(raw["board_static"]["outline_count"])
    following = np.arange(len(outline))
    ring = outline[:, 2]
    for r in np.unique(ring[:n]):
        members = np.flatnonzero(ring[:n] == r)
        following[members] = np.roll(members, -1)
    block = layout.block(EDGE)
    _put(table, nets, block, {X1: f.x(outline[:, 0]), Y1: f.y(outline[:, 1]),
                              X2: f.x(outline[following, 0]), Y2: f.y(outline[following, 1]),
                              CODE: ring, LAYER_LO: -1.0, LAYER_HI: -1.0})
    valid[block.start:block.start + n] = 1


def _net_boxes(pads: np.ndarray, count: int) -> np.ndarray:
    """Per net index: the bounding box of its pad centres (min x, min y, max x, max y)."""
    box = np.zeros((count, 4))
    mine = pads[:, 0] == 1
    index, xy = pads[mine, 1].astype(np.int64), pads[mine, 2:4]
    keep = (index >= 0) & (index < count)
    index, xy = index[keep], xy[keep]
    low = np.full((count, 2), np.inf)
    high = np.full((count, 2), -np.inf)
    np.minimum.at(low, index, xy)
    np.maximum.at(high, index, xy)
    seen = np.isfinite(low[:, 0])
    box[seen, :2], box[seen, 2:] = low[seen], high[seen]
    return box


def _net_rules(raw, f, layout, table, nets, valid):
    s = raw["board_static"]
    rows = s["nets"]  # valid, pads, clearance, track_width, via_diameter, via_drill
    n = len(rows)
    box = _net_boxes(s["pads"], n)
    block = layout.block(NET)
    _put(table, nets, block, {
        X1: f.x(box[:, 0]), Y1: f.y(box[:, 1]), X2: f.x(box[:, 2]), Y2: f.y(box[:, 3]),
        S1: f.size(rows[:, 2]), S2: f.size(rows[:, 3]), S3: f.size(rows[:, 4]),
        S4: f.size(rows[:, 5]), LAYER_LO: -1.0, LAYER_HI: -1.0, COUNT: rows[:, 1]},
        net_a=np.arange(n))
    valid[block] = rows[:, 0] == 1


def _net_state(raw, masks, layout, table):
    """a: the net may be selected now; b: it is the current net."""
    block = layout.block(NET)
    table[block, A] = masks["net"][: block.stop - block.start]
    table[block, B] = 0.0
    current = int(raw["router_head"]["net"])
    if current >= 0:
        table[block.start + current, B] = 1.0


def _pad_shapes(raw, f, layout, table, nets, valid):
    s = raw["board_static"]
    rows, on = s["pads"], s["pad_layers"]  # valid, net, x, y, size_x, size_y, shape, drill
    any_layer = on.any(axis=1)
    lo = np.where(any_layer, on.argmax(axis=1), -1)
    hi = np.where(any_layer, on.shape[1] - 1 - on[:, ::-1].argmax(axis=1), -1)
    block = layout.block(PAD)
    x, y = f.x(rows[:, 2]), f.y(rows[:, 3])
    _put(table, nets, block, {
        X1: x, Y1: y, X2: x, Y2: y, S1: f.size(rows[:, 4]), S2: f.size(rows[:, 5]),
        S3: f.size(rows[:, 7]), LAYER_LO: f.layer(lo), LAYER_HI: f.layer(hi), CODE: rows[:, 6]},
        net_a=rows[:, 1])
    valid[block] = rows[:, 0] == 1


def _pad_state(raw, layout, table):
    """a: the pad shares KiCad copper with another pad of its net."""
    table[layout.block(PAD), A] = raw["routing_geometry"]["pad_connected"]


def _segments(rows, f, first: int):
    """Normalised x1, y1, x2, y2 of rows whose positions start at column `first`."""
    return {c: (f.x if i % 2 == 0 else f.y)(rows[:, first + i])
            for i, c in enumerate((X1, Y1, X2, Y2))}


def _tracks(raw, f, layout, table, nets, valid):
    rows = raw["routing_geometry"]["tracks"]  # valid, net, layer, arc, x1, y1, x2, y2, width
    is_valid = rows[:, 0] == 1
    layer = f.layer(rows[:, 2])
    block = layout.block(TRACK)
    _put(table, nets, block, {**_segments(rows, f, 4), S1: f.size(rows[:, 8]),
                              LAYER_LO: layer, LAYER_HI: layer, CODE: rows[:, 3]},
         net_a=rows[:, 1])
    valid[block] = is_valid


def _vias(raw, f, layout, table, nets, valid):
    rows = raw["routing_geometry"]["vias"]  # valid, net, x, y, diameter, drill
    is_valid = rows[:, 0] == 1
    x, y = f.x(rows[:, 2]), f.y(rows[:, 3])
    block = layout.block(VIA)
    _put(table, nets, block, {X1: x, Y1: y, X2: x, Y2: y, S1: f.size(rows[:, 4]),
                              S2: f.size(rows[:, 5]), LAYER_LO: 0.0,
                              LAYER_HI: 1.0},
         net_a=rows[:, 1])
    valid[block] = is_valid


def _ratsnest(raw, f, layout, table, nets, valid):
    rows = raw["routing_geometry"]["ratsnest"]  # valid, net, x1, y1, x2, y2
    is_valid = rows[:, 0] == 1
    length = np.hypot(rows[:, 4] - rows[:, 2], rows[:, 5] - rows[:, 3])
    block = layout.block(RATSNEST)
    _put(table, nets, block, {**_segments(rows, f, 2), S1: f.size(length),
                              LAYER_LO: -1.0, LAYER_HI: -1.0},
         net_a=rows[:, 1])
    valid[block] = is_valid


def _head(raw, f, layout, table, nets, valid):
    h = raw["router_head"]
    has_head = int(h["layer"]) >= 0
    x, y = (float(f.x(h["position"][0])), float(f.y(h["position"][1]))) if has_head else (0, 0)
    layer = float(f.layer(int(h["layer"])))
    row = layout.block(HEAD).start
    table[row, [X1, Y1, X2, Y2, LAYER_LO, LAYER_HI, CODE, A, COUNT]] = (
        x, y, x, y, layer, layer, int(h["phase"]), has_head, float(raw["step"]))
    nets[row, 0] = int(h["net"])
    valid[row] = 1


def _candidates(raw, masks, f, layout, table, nets, valid):
    rows = raw["router_head"]["candidates"]  # kind, x, y, layer
    is_valid = rows[:, 0] > 0
    x, y = f.x(rows[:, 1]), f.y(rows[:, 2])
    layer = f.layer(rows[:, 3])
    block = layout.block(CANDIDATE)
    _put(table, nets, block, {X1: x, Y1: y, X2: x, Y2: y, LAYER_LO: layer,
                              LAYER_HI: layer, CODE: rows[:, 0],
                              A: masks["candidate"], B: masks["candidate_via"]},
         net_a=int(raw["router_head"]["net"]))
    valid[block] = is_valid


def _violations(raw, f, layout, table, nets, valid):
    rows = raw["drc"]["violations"]  # valid, type, severity, x, y, net_a, net_b
    is_valid = rows[:, 0] == 1
    x, y = f.x(rows[:, 3]), f.y(rows[:, 4])
    block = layout.block(VIOLATION)
    _put(table, nets, block, {X1: x, Y1: y, X2: x, Y2: y, LAYER_LO: -1.0,
                              LAYER_HI: -1.0, CODE: rows[:, 1], A: rows[:, 2] == 1},
         net_a=rows[:, 5], net_b=rows[:, 6])
    valid[block] = is_valid

"""The observation: a nested dict of fixed-size arrays, positions and sizes in mm (exact
conversions of KiCad's integer nanometres), items in a deterministic order, each list padded
with zero rows and led by a `valid` column. Net columns hold the net's action index (-1: none),
layer columns the copper layer's index in `layers` (KiCad's stack order, F.Cu first).
"""
from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np
from gymnasium import spaces

from pcbdata.core.ratsnest import open_pairs
from pcbdata.env.types import PHASES, Candidate, Head, StaticBoard

MAX_LAYERS = 32
#: The bound of `step` when the step limit is per board (the `max_steps` option unset).
MAX_STEP_COUNT = 10**6
PAD_SHAPES = ("other", "Circle", "Rect", "Oval", "Trapezoid", "Roundrect", "Chamferedrect",
              "Custom")
DRC_TYPES = ("other", "unconnected_items", "clearance", "shorting_items", "tracks_crossing",
             "copper_edge_clearance", "track_dangling", "via_dangling", "net_conflict",
             "items_not_allowed", "hole_clearance", "hole_to_hole", "track_width",
             "via_diameter", "annular_width", "drill_out_of_range", "solder_mask_bridge",
             "silk_overlap", "starved_thermal", "isolated_copper", "lib_footprint_mismatch")
SEVERITIES = ("other", "error", "warning", "ignore", "excluded")
COLUMNS = {"outline": ("x", "y", "ring"),
           "nets": ("valid", "pads", "clearance", "track_width", "via_diameter", "via_drill"),
           "pads": ("valid", "net", "x", "y", "size_x", "size_y", "shape", "drill"),
           "tracks": ("valid", "net", "layer", "arc", "x1", "y1", "x2", "y2", "width"),
           "vias": ("valid", "net", "x", "y", "diameter", "drill"),
           "ratsnest": ("valid", "net", "x1", "y1", "x2", "y2"),
           "candidates": ("kind", "x", "y", "layer"),
           "violations": ("valid", "type", "severity", "x", "y", "net_a", "net_b")}


#: Bound of every real-valued entry: mm (a board is far below 1 km), indices and codes.
LIMIT = 1e6


def _rows(n: int, name: str) -> spaces.Box:
    return spaces.Box(-LIMIT, LIMIT, (n, len(COLUMNS[name])), np.float64)


def _count(high: int) -> spaces.Box:
    return spaces.Box(0, high, (), np.int64)


def observation_space(o) -> spaces.Dict:
    """The space for options `o` (capacities from `pcbdata.env.options`)."""
    return spaces.Dict({
        "board_static": spaces.Dict({
            "n_layers": _count(MAX_LAYERS), "outline": _rows(o.max_outline_points, "outline"),
            "outline_count": _count(o.max_outline_points),
            "rules": spaces.Box(0, LIMIT, (5,), np.float64),
            "nets": _rows(o.max_nets, "nets"), "net_count": _count(10**6),
            "pads": _rows(o.max_pads, "pads"),
            "pad_layers": spaces.Box(0, 1, (o.max_pads, MAX_LAYERS), np.int8)}),
        "routing_geometry": spaces.Dict({
            "tracks": _rows(o.max_tracks, "tracks"), "track_count": _count(o.max_tracks),
            "vias": _rows(o.max_vias, "vias"), "via_count": _count(o.max_vias),
            "pad_connected": spaces.Box(0, 1, (o.max_pads,), np.int8),
            "ratsnest": _rows(o.max_ratsnest, "ratsnest"),
            "ratsnest_count": _count(o.max_ratsnest), "unconnected": _count(10**6)}),
        "router_head": spaces.Dict({
            "phase": spaces.Discrete(len(PHASES)),
            "net": spaces.Box(-1, o.max_nets - 1, (), np.int64),
            "position": spaces.Box(-LIMIT, LIMIT, (2,), np.float64),
            "layer": spaces.Box(-1, MAX_LAYERS - 1, (), np.int64),
            "candidates": _rows(o.max_candidates, "candidates")}),
        "drc": spaces.Dict({"violations": _rows(o.max_violations, "violations"),
                            "count": _count(o.max_violations), "total": _count(10**7)}),
        "step": _count(o.max_steps or MAX_STEP_COUNT),
    })


def _fill(space: Any, rows: list[tuple]) -> tuple[np.ndarray, np.ndarray]:
    out = np.zeros(space.shape, dtype=space.dtype)
    rows = rows[: space.shape[0]]
    if rows:
        out[: len(rows)] = np.asarray(rows, dtype=space.dtype)
    return out, _int(len(rows))


def _int(value) -> np.ndarray:
    """A 0-d int64 array (what a shape-() Box holds)."""
    return np.asarray(value, dtype=np.int64)


def mm(value: int) -> float:
    return value / 1e6


def board_rules(static: StaticBoard) -> tuple:
    """The board's rules: those most nets share (per-net values are in `nets`)."""
    rows = [(n.clearance, n.track_width, n.via_diameter, n.via_drill) for n in static.nets]
    common = max(sorted(set(rows)), key=rows.count) if rows else (0, 0, 0, 0)
    return tuple(mm(v) for v in common) + (mm(static.edge_clearance),)


def _shape_code(shape: str) -> int:
    key = shape.replace(" ", "").lower()
    return next((i for i, s in enumerate(PAD_SHAPES) if s.lower() == key), 0)


def static_part(static: StaticBoard, space: Any) -> dict:
    """`board_static`, built once per episode."""
    net_index = {n.name: i for i, n in enumerate(static.nets)}
    outline = [(mm(x), mm(y), r) for r, ring in enumerate(static.outline) for x, y in ring]
    nets = [(1, len(static.pads_of(n.name)), mm(n.clearance), mm(n.track_width),
             mm(n.via_diameter), mm(n.via_drill)) for n in static.nets]
    pads = [(1, net_index.get(p.net, -1), mm(p.x), mm(p.y), mm(p.size[0]), mm(p.size[1]),
             _shape_code(p.shape), mm(p.drill)) for p in static.pads]
    layers = np.zeros(space["pad_layers"].shape, dtype=np.int8)
    for i, pad in enumerate(static.pads[: layers.shape[0]]):
        layers[i, list(pad.layers)] = 1
    outline_rows, outline_count = _fill(space["outline"], outline)
    return {"n_layers": _int(len(static.layers)), "outline": outline_rows,
            "outline_count": outline_count,
            "rules": np.asarray(board_rules(static), dtype=np.float64),
            "nets": _fill(space["nets"], nets)[0], "net_count": _int(static.net_count),
            "pads": _fill(space["pads"], pads)[0], "pad_layers": layers}


def _copper_rows(static: StaticBoard, copper: list[dict]) -> tuple[list, list]:
    net_index = {n.name: i for i, n in enumerate(static.nets)}
    layer = {name: i for i, name in enumerate(static.layers)}
    tracks, vias = [], []
    for r in copper:
        net = net_index.get(r["net"], -1)
        if r["kind"] == "via":
            vias.append((1, net, mm(r["x"]), mm(r["y"]), mm(r["diameter"]), mm(r["drill"])))
        else:
            tracks.append((1, net, layer.get(r["layer"], -1), float(r["kind"] == "arc"),
                           mm(r["start"][0]), mm(r["start"][1]), mm(r["end"][0]),
                           mm(r["end"][1]), mm(r["width"])))
    return sorted(tracks), sorted(vias)


def ratsnest(static: StaticBoard, pad_cluster: list[int]) -> list[tuple]:
    """Open connections as pcbdata draws them from KiCad's clusters (`pcbdata.core.ratsnest`)."""
    net_index = {n.name: i for i, n in enumerate(static.nets)}
    points = [(p.x, p.y) for p in static.pads]
    pairs = open_pairs(points, [static.pads_of(n.name) for n in static.nets], pad_cluster)
    return [(1, net_index[static.pads[a].net], mm(static.pads[a].x), mm(static.pads[a].y),
             mm(static.pads[b].x), mm(static.pads[b].y)) for a, b in pairs]


def geometry_part(static: StaticBoard, snap: dict, space: Any) -> tuple[dict, bool]:
    """`routing_geometry` and whether a list had to be cut to its capacity."""
    tracks, vias = _copper_rows(static, snap["copper"])
    labels = snap["pad_cluster"]
    connected = np.zeros(space["pad_connected"].shape, dtype=np.int8)
    shown = static.pads[: connected.shape[0]]
    if shown:  # a pad is connected where another pad of its net shares its cluster
        sharing = Counter((pad.net, labels[i]) for i, pad in enumerate(static.pads))
        connected[: len(shown)] = [sharing[pad.net, labels[i]] > 1
                                   for i, pad in enumerate(shown)]
    edges = ratsnest(static, labels)
    track_rows, track_count = _fill(space["tracks"], tracks)
    via_rows, via_count = _fill(space["vias"], vias)
    edge_rows, edge_count = _fill(space["ratsnest"], edges)
    cut = bool(len(tracks) > track_count or len(vias) > via_count or len(edges) > edge_count)
    return {"tracks": track_rows, "track_count": track_count, "vias": via_rows,
            "via_count": via_count, "pad_connected": connected, "ratsnest": edge_rows,
            "ratsnest_count": edge_count, "unconnected": _int(snap["unconnected"])}, cut


def head_part(static: StaticBoard, phase: int, net: str | None, head: Head | None,
              cands: list[Candidate], space: Any) -> dict:
    rows = [(c.kind, mm(c.x), mm(c.y), c.layer) for c in cands]
    return {"phase": np.int64(phase),
            "net": _int(static.net_index(net) if net is not None else -1),
            "position": np.asarray((mm(head.x), mm(head.y)) if head else (0.0, 0.0)),
            "layer": _int(head.layer if head else -1),
            "candidates": _fill(space["candidates"], rows)[0]}


def _code(table: tuple, value: str) -> int:
    return table.index(value) if value in table else 0


def drc_part(static: StaticBoard, counted: list[dict], space: Any) -> dict:
    """The first violations (canonical order) of those the reward counts, unconnected items
    left out: KiCad picks the items an unconnected edge names in an order that varies from run
    to run, so open connections are given by the deterministic `routing_geometry.ratsnest`.
    `total` counts them all."""
    net_index = {n.name: i for i, n in enumerate(static.nets)}
    rows = []
    for v in counted:
        if v["section"] == "unconnected":
            continue
        x, y = v["positions"][0] if v.get("positions") else (0.0, 0.0)
        nets = [net_index.get(n, -1) for n in v["nets"]] + [-1, -1]
        rows.append((1, _code(DRC_TYPES, v["type"]), _code(SEVERITIES, v["severity"]), x, y,
                     nets[0], nets[1]))
    violation_rows, count = _fill(space["violations"], rows)
    return {"violations": violation_rows, "count": count, "total": _int(len(counted))}

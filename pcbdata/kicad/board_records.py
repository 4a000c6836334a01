"""A `.kicad_pcb` as plain drawing records (`pcbdata.core.drawing`), read by KiCad in a `KicadPool`
worker: outline, pads with KiCad's polygons per copper layer, tracks, arcs, vias, filled zones
and copper drawings, and the ratsnest of KiCad's connectivity (integer nanometres).

The item readers are the routing environment's (`routing_session`), so a board drawn from a
file looks like the same board drawn by the environment.
"""
from __future__ import annotations

import os
import shutil
import tempfile

from pcbdata.core.ratsnest import open_pairs
from pcbdata.core.tree import BOARD_FILE
from pcbdata.kicad.basics import load_board, stage_with_project
from pcbdata.kicad.board_reading import (
    graphic_records,
    located_violations,
    outline_rings,
    pad_record,
    track_record,
    zone_records,
)
from pcbdata.kicad.scoring import copper_labels


def ratsnest_edges(pads: list[dict], labels: list[int]) -> list[tuple[int, int, int, int]]:
    """Open connections from KiCad's copper clusters, drawn as the environment's observation
    draws them (`pcbdata.core.ratsnest`), nets in name order."""
    by_net: dict[str, list[int]] = {}
    for i, pad in enumerate(pads):
        if pad["net"]:
            by_net.setdefault(pad["net"], []).append(i)
    points = [(pad["x"], pad["y"]) for pad in pads]
    pairs = open_pairs(points, [by_net[net] for net in sorted(by_net)], labels)
    return [(pads[a]["x"], pads[a]["y"], pads[b]["x"], pads[b]["y"]) for a, b in pairs]


def _records(board) -> dict:
    board.BuildConnectivity()
    layers = {board.GetLayerName(i): int(i) for i in board.GetEnabledLayers().CuStack()}
    names = {lid: name for name, lid in layers.items()}
    pad_items, tracks = list(board.GetPads()), list(board.GetTracks())
    pads = [pad_record(board, p, layers) for p in pad_items]
    labels = copper_labels(board, pad_items + tracks + list(board.Zones()))
    copper = [track_record(t, names, 0) for t in tracks]
    try:
        outline = outline_rings(board)
    except ValueError:  # an open outline: draw the items only
        outline = []
    zones = [{"layer": z["layer"], "polygon": z["polygon"]}
             for z in zone_records(board, layers) + graphic_records(board, layers)]
    return {"layers": list(layers), "outline": outline,
            "pads": [{k: p[k] for k in ("net", "x", "y", "drill", "polygons")} for p in pads],
            "zones": zones, "tracks": [c for c in copper if c["kind"] != "via"],
            "vias": [c for c in copper if c["kind"] == "via"],
            "ratsnest": ratsnest_edges(pads, labels[:len(pads)]),
            "unconnected": int(board.GetConnectivity().GetUnconnectedCount(False))}


def _markers(board) -> list[tuple[int, int]]:
    """Positions (nm) of KiCad's DRC errors under the board's project, unconnected items left
    out (the ratsnest shows them): the first item each violation names."""
    return sorted((round(v["positions"][0][0] * 1e6), round(v["positions"][0][1] * 1e6))
                  for v in located_violations(board) if v["severity"] == "error"
                  and v["section"] != "unconnected" and v["positions"])


def read_board(path: str, project: str | None = None, rules: str | None = None,
               drc: bool = False) -> dict:
    """The board file's drawing records; with `drc`, the positions of KiCad's DRC errors under
    `project` (and custom `rules`; KiCad's defaults without a project) as `markers`. KiCad
    reads private copies (it writes lock files beside the board it loads)."""
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such board file")
    with tempfile.TemporaryDirectory(prefix="pcbdata-render-") as tmp:
        if project is not None:
            copy = stage_with_project(path, project, rules, tmp, stem="board")
        else:
            copy = os.path.join(tmp, BOARD_FILE)
            shutil.copyfile(path, copy)
        board = load_board(copy)
        records = _records(board)
        if drc:
            records["markers"] = _markers(board)
        return records

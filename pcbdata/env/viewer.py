"""`render_mode="rgb_array"`: the environment's current state as drawing records
(`pcbdata.core.drawing`), from what the environment already holds (no KiCad round trip)."""
from __future__ import annotations

from pcbdata.env.observation import ratsnest
from pcbdata.env.types import Head, StaticBoard

RENDER_MODES = ["rgb_array"]
#: Width and height of the rendered image (pixels); the board is fitted inside, aspect kept.
RENDER_SIZE = (640, 480)


def _nm(value_mm: float) -> int:
    return round(value_mm * 1e6)


def _copper(snap: dict) -> tuple[list[dict], list[dict]]:
    tracks, vias = [], []
    for record in snap["copper"]:
        if record["kind"] == "via":
            vias.append(record)
        else:
            tracks.append(record)
    return tracks, vias


def state_records(static: StaticBoard, snap: dict, head: Head | None,
                  counted: list[dict]) -> dict:
    """Drawing records of a state: the static board, the snapshot's copper, the ratsnest of
    its clusters (the observation's), the head and the positions of the counted DRC violations
    (unconnected items left out: they are the ratsnest)."""
    tracks, vias = _copper(snap)
    edges = [tuple(_nm(v) for v in row[2:]) for row in ratsnest(static, snap["pad_cluster"])]
    markers = [(_nm(v["positions"][0][0]), _nm(v["positions"][0][1])) for v in counted
               if v.get("section") != "unconnected" and v.get("positions")]
    zones = [{"layer": z["layer"], "polygon": z["polygon"]}
             for z in (*static.zones, *static.graphics)]
    pads = [{"x": p.x, "y": p.y, "drill": p.drill, "polygons": p.polygons} for p in static.pads]
    return {"layers": list(static.layers), "outline": [list(r) for r in static.outline],
            "pads": pads, "zones": zones, "tracks": tracks, "vias": vias, "ratsnest": edges,
            "head": (head.x, head.y, static.layers[head.layer]) if head else None,
            "markers": sorted(markers)}

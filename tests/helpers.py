"""Small helpers shared by tests: writing boards and reading them back with sexpdata, and the
one way a test skips for want of the PCBench snapshot."""
from __future__ import annotations

import os
from pathlib import Path
from typing import NoReturn

import pytest
import sexpdata

#: Set to 1 (CI: `.ci/run`) and a test that needs the PCBench snapshot fails instead of skipping.
REQUIRE_SNAPSHOT = "PCBDATA_REQUIRE_SNAPSHOT"


def skip_without_snapshot(why: str) -> NoReturn:
    """Skips the calling test (or fixture), saying `why`: the PCBench snapshot, or boards built
    from it, are not here. Fails it with the same message when PCBDATA_REQUIRE_SNAPSHOT=1, so a
    run that must have the snapshot cannot pass by skipping."""
    if os.environ.get(REQUIRE_SNAPSHOT) == "1":
        pytest.fail(f"{why} ({REQUIRE_SNAPSHOT}=1: the snapshot is required)", pytrace=False)
    pytest.skip(why)


def _head(node) -> str | None:
    if isinstance(node, list) and node and isinstance(node[0], sexpdata.Symbol):
        return node[0].value()
    return None


def _child(node, name: str):
    return next((c for c in node if _head(c) == name), None)


def parse_board(path: Path) -> list:
    return sexpdata.loads(Path(path).read_text())


def pads_in_file(path: Path) -> list[dict]:
    """Pads of a board file written by pcbdata: centre (mm), layer, type, shape, size, net."""
    out = []
    for node in parse_board(path):
        if _head(node) != "footprint":
            continue
        x, y = _child(node, "at")[1:3]
        pad = _child(node, "pad")
        out.append({"x": float(x), "y": float(y), "footprint_layer": _child(node, "layer")[1],
                    "type": pad[2].value(), "shape": pad[3].value(),
                    "size": tuple(float(v) for v in _child(pad, "size")[1:3]),
                    "layers": list(_child(pad, "layers")[1:]),
                    "drill": float(_child(pad, "drill")[1]) if _child(pad, "drill") else None,
                    "net": _child(pad, "net")[2]})
    return out


def outline_in_file(path: Path) -> tuple[tuple[float, float], tuple[float, float], str]:
    rect = next(n for n in parse_board(path) if _head(n) == "gr_rect")
    start, end = _child(rect, "start")[1:3], _child(rect, "end")[1:3]
    layer = _child(rect, "layer")[1]
    return (float(start[0]), float(start[1])), (float(end[0]), float(end[1])), layer

"""`pcbdata route --router kicad-tools`: the second baseline router, run as a separate process
with the instance's own rules (never its name-based net classes, never extra layers)."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from pcbdata.cli import main
from pcbdata.kicad import kicad_tools_route as kicad_tools
from pcbdata.testing.sets import seal_set

sys.path.insert(0, str(Path(__file__).parents[1] / "evaluator"))
from boards import base_board, pad, write_instance  # noqa: E402


def test_every_net_gets_the_instance_default_class(tmp_path):
    board = base_board(pads=[pad(10, 10, "GND"), pad(50, 10, "GND"), pad(10, 30, "VCC_5V"),
                             pad(50, 30, "VCC_5V")])
    write_instance(board, tmp_path / "b0")
    rules = kicad_tools.default_rules(str(tmp_path / "b0" / "board.kicad_pro"))
    text = (tmp_path / "b0" / "board.kicad_pcb").read_text()
    classes = kicad_tools.net_class_map(text, rules)
    assert sorted(k for k in classes if not k.startswith("_")) == ["GND", "VCC_5V"]
    widths = {c["trace_width"] for k, c in classes.items() if not k.startswith("_")}
    assert widths == {rules["track_width"]}
    argv = (kicad_tools.command("in", "out", rules, "map.json", 3, 60)
            if kicad_tools.executable() else [])
    if argv:
        assert argv[argv.index("--layers") + 1] == "2" and "--no-auto-layers" in argv


@pytest.mark.skipif(kicad_tools.executable() is None, reason="kicad-tools is not installed")
def test_route_with_kicad_tools_then_score(tmp_path):
    root = tmp_path / "set"
    board = base_board(pads=[pad(10, 10, "GND"), pad(40, 10, "GND"), pad(10, 25, "B"),
                             pad(40, 25, "B")])
    seal_set(write_instance(board, root / "d2" / "test" / "b0").parents[2])
    runs = tmp_path / "runs"
    assert main(["route", str(root), "--config", "d2", "--router", "kicad-tools", "--out",
                 str(runs), "--workers", "1", "--timeout", "240"]) == 0
    meta = json.loads((runs / "b0" / "0.json").read_text())
    assert meta["status"] == "routed", meta["reason"]
    assert meta["router"] == "kicad-tools --seed 0"
    assert meta["router_version"] == kicad_tools.version()
    assert meta["router_cpu_s"] is not None and meta["time_s"] > 0
    assert sorted(p.name for p in (runs / "b0").iterdir()) == ["0.json", "0.kicad_pcb"]
    assert main(["eval", str(root), "--config", "d2", "--runs", str(runs), "--out",
                 str(tmp_path / "rep"), "--workers", "1"]) == 0
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert summary["n_invalid"] == 0 and summary["rout"] == 1.0 and summary["cp"] == 1.0

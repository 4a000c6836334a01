"""D2 boards hold every via to the netclass size (SPEC section 2: "via 1.2 / drill 0.6" is a
rule): a router that shrinks its vias to pass a gap gets KiCad DRC errors, and loses CP."""
from __future__ import annotations

import json
import math
from dataclasses import replace

import pytest

from pcbdata.cli import main
from pcbdata.evaluator import score
from pcbdata.generators.d1 import D1Generator, D1Params
from pcbdata.generators.d2 import D2Generator, D2Params
from pcbdata.model.board import mm_to_nm
from pcbdata.model.kicad_writer import mm
from pcbdata.testing.sets import write_board

# Two nets of two through-hole pads: test board 37 has NET1 running nearly level across the
# board and NET2 crossing it, so NET2 can come down on F.Cu, drop through a via beside NET1's
# track and cross under it on B.Cu.
PARAMS = replace(D2Params(), net_counts=(2,), pads_per_net={"2": 1.0}, through_hole_fraction=1.0)
INDEX = 37
TIGHT_MM = 0.85  # via centre to NET1's track centre: 0.5 mm via fits, 1.2 mm does not
ROOMY_MM = 3.0


def _pads(board) -> dict[str, list[tuple[float, float]]]:
    out: dict[str, list[tuple[float, float]]] = {}
    for pad in board.pads:
        out.setdefault(pad.net, []).append((pad.x / 1e6, pad.y / 1e6))
    return out


def _via_spot(board, distance_mm: float) -> tuple[float, float]:
    """The point `distance_mm` from NET1's straight track, on the side of NET2's first pad,
    level with that pad."""
    (ax, ay), (bx, by) = _pads(board)["NET1"]
    px, py = _pads(board)["NET2"][0]
    dx, dy = bx - ax, by - ay
    t = ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)
    fx, fy = ax + t * dx, ay + t * dy
    side = math.hypot(px - fx, py - fy)
    return fx + distance_mm * (px - fx) / side, fy + distance_mm * (py - fy) / side


def _segment(start, end, layer: str, net: int) -> str:
    (x1, y1), (x2, y2) = ((mm(mm_to_nm(x)), mm(mm_to_nm(y))) for x, y in (start, end))
    return (f"\t(segment (start {x1} {y1}) (end {x2} {y2}) (width 0.3) (layer \"{layer}\") "
            f"(net {net}))\n")


def _routed_text(instance_text: str, board, distance_mm: float, via: tuple[float, float]) -> str:
    """The instance with both nets routed by hand: NET1 straight on F.Cu; NET2 on F.Cu to a
    via `distance_mm` from NET1's track, then on B.Cu to its other pad."""
    pads = _pads(board)
    spot = _via_spot(board, distance_mm)
    x, y = (mm(mm_to_nm(v)) for v in spot)
    size, drill = via
    items = (_segment(*pads["NET1"], "F.Cu", 1) + _segment(pads["NET2"][0], spot, "F.Cu", 2)
             + _segment(spot, pads["NET2"][1], "B.Cu", 2)
             + f"\t(via (at {x} {y}) (size {size}) (drill {drill}) (layers \"F.Cu\" \"B.Cu\") "
               "(net 2))\n")
    end = instance_text.rindex("\t(embedded_fonts no)")
    return instance_text[:end] + items + instance_text[end:]


@pytest.fixture(scope="module")
def instance(tmp_path_factory):
    board = D2Generator(PARAMS).generate(0, "test", INDEX).board
    assert sorted(_pads(board)) == ["NET1", "NET2"]
    folder = tmp_path_factory.mktemp("d2-vias") / "instance"
    write_board(folder, board)
    return folder, board


@pytest.mark.parametrize("distance, via, expected", [
    (ROOMY_MM, (1.2, 0.6), {}),
    (TIGHT_MM, (1.2, 0.6), {"clearance": 1}),  # the gap is too narrow for an honest via
    (TIGHT_MM, (0.5, 0.3), {"drill_out_of_range": 1, "via_diameter": 1}),
    (ROOMY_MM, (1.0, 0.6), {"via_diameter": 1}),  # each floor on its own
    (ROOMY_MM, (1.2, 0.4), {"drill_out_of_range": 1}),
], ids=["netclass-via-with-room", "netclass-via-in-the-gap", "small-via-in-the-gap",
        "thinner-via", "smaller-drill"])
def test_only_a_netclass_size_via_routes_clean(kicad_pool, instance, tmp_path, distance, via,
                                               expected):
    folder, board = instance
    text = (folder / "board.kicad_pcb").read_text(encoding="utf-8")
    routed = tmp_path / "routed.kicad_pcb"
    routed.write_text(_routed_text(text, board, distance, via), encoding="utf-8")
    record = score(folder, routed, pool=kicad_pool)
    assert record["status"] == "ok", record["reason"]
    assert (record["rout"], record["unconnected"], record["via"]) == (1.0, 0, 1)
    # counted by the evaluation count: KiCad reports both via checks as errors
    assert record["drv_by_type"] == record["drv_strict_by_type"] == expected
    assert record["cp"] == int(not expected)


def test_every_level_writes_its_via_size_as_the_project_minimum(tmp_path, capsys):
    assert main(["levels", "--json"]) == 0
    levels = json.loads(capsys.readouterr().out)
    assert "default" in levels and len(levels) >= 4
    for name, params in levels.items():
        board = D2Generator(D2Params.from_dict(params, name)).generate(0, "test", 0).board
        write_board(tmp_path / name, board)
        project = json.loads((tmp_path / name / "board.kicad_pro").read_text())
        rules = project["board"]["design_settings"]["rules"]
        netclass = project["net_settings"]["classes"][0]
        assert rules["min_via_diameter"] == netclass["via_diameter"] == params["via_diameter_mm"]
        assert (rules["min_through_hole_diameter"] == netclass["via_drill"]
                == params["via_drill_mm"]), name
        # no severity is written: KiCad's defaults make both via checks errors (test above)
        assert "rule_severities" not in project["board"]["design_settings"]


def test_d1_keeps_its_floors_as_its_custom_rule_forbids_every_via(tmp_path):
    board = D1Generator(D1Params(grid=10)).generate(0, "test", 0).board
    write_board(tmp_path, board)
    rules = json.loads((tmp_path / "board.kicad_pro").read_text())["board"]["design_settings"]
    assert (rules["rules"]["min_via_diameter"], rules["rules"]["min_through_hole_diameter"]) == (
        0.5, 0.3)
    assert "disallow track via" in (tmp_path / "board.kicad_dru").read_text()

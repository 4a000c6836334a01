"""D1 exactly as SPEC section 1: geometry, rules, placement, the one-layer rule, arrays."""
import json
from dataclasses import replace

import numpy as np
import pytest

from pcbdata.core.errors import UserError
from pcbdata.generators.d1 import D1Generator, D1Params
from pcbdata.kicad import DrcReport
from pcbdata.model.board import Via, mm_to_nm
from pcbdata.model.connector import connector_arrays, npz_bytes
from pcbdata.model.kicad_writer import board_files
from pcbdata.testing.sets import write_board
from tests.helpers import outline_in_file, pads_in_file

GRIDS = (10, 50, 100, 200, 500)


@pytest.mark.parametrize("grid", GRIDS)
def test_geometry_and_rules_follow_the_spec(grid, tmp_path):
    g = 100 / grid
    instance = D1Generator(D1Params(grid=grid)).generate(0, "test", 3)
    path = write_board(tmp_path, instance.board)
    pads = pads_in_file(path)
    assert len(pads) == 10
    assert [p["net"] for p in pads] == [f"NET{k}" for k in range(1, 6) for _ in range(2)]
    for pad, cell in zip(pads, [c for pair in instance.cells for c in pair]):
        i, j = cell
        assert (pad["x"], pad["y"]) == pytest.approx(((i + 0.75) * g, (j + 0.75) * g), abs=1e-9)
        assert pad["size"] == pytest.approx((g / 2, g / 2)) and pad["shape"] == "rect"
        assert pad["type"] == "smd" and pad["layers"][0] == "F.Cu"
    cells = [c for pair in instance.cells for c in pair]
    assert len(set(cells)) == 10 and all(0 <= i < grid and 0 <= j < grid for i, j in cells)
    assert outline_in_file(path) == ((0, 0), (100 + g / 2, 100 + g / 2), "Edge.Cuts")
    project = json.loads((tmp_path / "board.kicad_pro").read_text())
    netclass = project["net_settings"]["classes"][0]
    assert netclass["name"] == "Default"
    assert netclass["clearance"] == netclass["track_width"] == pytest.approx(g / 2)
    assert (netclass["via_diameter"], netclass["via_drill"]) == (0.6, 0.3)
    rules = project["board"]["design_settings"]["rules"]
    assert rules["min_copper_edge_clearance"] == pytest.approx(g / 2)
    assert '(layer "B.Cu")' in (tmp_path / "board.kicad_dru").read_text()


def test_pads_are_drawn_uniformly_over_cells():
    grid, boards = 10, 2000
    generator = D1Generator(D1Params(grid=grid))
    counts = np.zeros(grid * grid)
    for index in range(boards):
        for pair in generator.generate(0, "train", index).cells:
            for i, j in pair:
                counts[i * grid + j] += 1
    expected = boards * 10 / grid ** 2
    # Chi-square with 99 degrees of freedom: mean 99, sd 14; 99 + 5 sd is far beyond chance.
    chi2 = ((counts - expected) ** 2 / expected).sum()
    assert chi2 < 99 + 5 * 14


def test_seed_streams_are_disjoint_per_grid_split_and_index():
    generator = D1Generator(D1Params(grid=50))
    cells = {(split, i): generator.generate(0, split, i).cells
             for split in ("train", "validation", "test") for i in range(20)}
    assert len({json.dumps(c) for c in cells.values()}) == 60
    assert generator.generate(0, "test", 5).cells == cells[("test", 5)]
    assert D1Generator(D1Params(grid=100)).generate(0, "test", 5).cells != cells[("test", 5)]
    assert generator.generate(1, "test", 5).cells != cells[("test", 5)]


def test_generated_boards_pass_drc_with_only_their_unconnected_items(kicad_pool, tmp_path):
    paths = []
    for grid in GRIDS:
        for placement in ("uniform", "random-walk"):
            for index in range(4):
                generator = D1Generator(D1Params(grid=grid, placement=placement))
                board = generator.generate(0, "test", index).board
                paths.append((str(write_board(tmp_path / f"{grid}-{placement}-{index}", board)),))
    for outcome in kicad_pool.map("pcbdata.kicad.basics:drc", paths):
        report = DrcReport.from_dict(outcome.value)
        assert report.counts_by_type() == {"unconnected_items": 5}, paths[outcome.index]


def _routed_reference(grid: int, index: int):
    return D1Generator(D1Params(grid=grid, placement="random-walk")).generate(0, "test", index)


@pytest.mark.parametrize("grid", GRIDS)
def test_random_walk_reference_routing_is_clean_and_fully_connected(grid, kicad_pool, tmp_path):
    paths = []
    for index in range(3):
        instance = _routed_reference(grid, index)
        assert instance.reference is not None and instance.reference.tracks
        assert [p for p in instance.reference.pads] == instance.board.pads
        for start, target in instance.cells:
            assert start != target
        paths.append((str(write_board(tmp_path / str(index), instance.reference)),))
    for outcome in kicad_pool.map("pcbdata.kicad.basics:drc", paths):
        assert outcome.ok, outcome.error
        assert DrcReport.from_dict(outcome.value).violations == [], paths[outcome.index]


def test_one_layer_rule_is_enforced_by_drc(kicad_pool, tmp_path):
    instance = _routed_reference(10, 0)
    reference = instance.reference
    first = reference.tracks[0]
    on_back = replace(reference, tracks=[replace(first, layer="B.Cu")] + reference.tracks[1:])
    with_via = replace(reference, vias=[Via(x=first.x1, y=first.y1, diameter=mm_to_nm(0.6),
                                            drill=mm_to_nm(0.3), net=first.net)])
    paths = [(str(write_board(tmp_path / "back", on_back)),),
             (str(write_board(tmp_path / "via", with_via)),)]
    outcomes = sorted(kicad_pool.map("pcbdata.kicad.basics:drc", paths), key=lambda o: o.index)
    for outcome in outcomes:
        report = DrcReport.from_dict(outcome.value)
        flagged = [v for v in report.violations if v.type == "items_not_allowed"]
        assert flagged and flagged[0].severity == "error"
        assert "single_layer_routing" in flagged[0].message


def test_connector_rows_describe_the_same_pins_as_the_boards(tmp_path):
    grid = 200
    generator = D1Generator(D1Params(grid=grid))
    instances = [generator.generate(0, "validation", i) for i in range(8)]
    data = npz_bytes(connector_arrays([x.board_id for x in instances], [x.cells for x in instances],
                                      grid, "test-version"))
    (tmp_path / "validation.npz").write_bytes(data)
    arrays = np.load(tmp_path / "validation.npz")
    assert arrays["starts"].dtype == np.int32 and arrays["starts"].shape == (8, 5, 2)
    assert arrays["targets"].shape == (8, 5, 2)
    assert int(arrays["num_agents"]) == 5 and int(arrays["grid_size"]) == grid
    assert str(arrays["connector_version"]) == "test-version"
    g = 100 / grid
    for row, instance in enumerate(instances):
        assert arrays["board_ids"][row] == instance.board_id
        path = write_board(tmp_path / instance.board_id, instance.board)
        pads = pads_in_file(path)
        for k in range(5):
            cells = (arrays["starts"][row, k], arrays["targets"][row, k])
            for pad, cell in zip(pads[2 * k: 2 * k + 2], cells):
                centre = ((cell[0] + 0.75) * g, (cell[1] + 0.75) * g)
                assert (pad["x"], pad["y"]) == pytest.approx(centre)
                assert pad["net"] == f"NET{k + 1}"
    assert npz_bytes(connector_arrays([x.board_id for x in instances], [x.cells for x in instances],
                                      grid, "test-version")) == data


@pytest.mark.parametrize("grid", [1, 0, -3, 3])
def test_impossible_grid_sizes_are_rejected(grid):
    with pytest.raises(UserError, match="grid"):
        D1Params(grid=grid)


def test_boards_and_files_are_byte_identical_for_the_same_seed():
    a = board_files(D1Generator(D1Params(grid=50)).generate(7, "train", 42).board)
    b = board_files(D1Generator(D1Params(grid=50)).generate(7, "train", 42).board)
    assert a == b

"""D2 as SPEC section 2: distributions over the 10 000 training boards, geometry, rules, levels."""
import json
import math
from collections import Counter

import pytest

from pcbdata.core.errors import GenerationError, UserError
from pcbdata.generators.d2 import D2Generator, D2Params
from pcbdata.kicad import DrcReport
from pcbdata.model.board import mm_to_nm
from pcbdata.sets.presets import level as preset_level
from pcbdata.sets.presets import levels as preset_levels
from pcbdata.sets.presets import parse_override
from pcbdata.testing.sets import write_board
from tests.helpers import pads_in_file

N_TRAIN = 10_000


def _tolerance(p: float, n: int, sigmas: float = 5.0) -> float:
    """A proportion's allowed deviation: `sigmas` binomial standard deviations."""
    return sigmas * math.sqrt(p * (1 - p) / n)


@pytest.fixture(scope="module")
def train_boards():
    generator = D2Generator(D2Params())
    return [generator.generate(0, "train", i).board for i in range(N_TRAIN)]


def test_net_count_is_uniform_over_4_5_6(train_boards):
    counts = Counter(len(b.net_names) for b in train_boards)
    assert set(counts) == {4, 5, 6}
    for value in (4, 5, 6):
        assert abs(counts[value] / N_TRAIN - 1 / 3) < _tolerance(1 / 3, N_TRAIN)


def test_pads_per_net_follow_the_distribution(train_boards):
    sizes = Counter()
    for board in train_boards:
        sizes.update(Counter(p.net for p in board.pads).values())
    nets = sum(sizes.values())
    for k, p in {2: 0.6, 3: 0.2, 4: 0.1, 5: 0.1}.items():
        assert abs(sizes[k] / nets - p) < _tolerance(p, nets), k
    assert set(sizes) == {2, 3, 4, 5}
    pads = [b.n_pads for b in train_boards]
    assert 8 <= min(pads) and max(pads) <= 30
    mean_pads = 5 * (2 * 0.6 + 3 * 0.2 + 4 * 0.1 + 5 * 0.1)
    sd = math.sqrt(sum((n - mean_pads) ** 2 for n in pads) / N_TRAIN)
    assert abs(sum(pads) / N_TRAIN - mean_pads) < 5 * sd / math.sqrt(N_TRAIN)


def test_board_sides_are_uniform_80_to_120(train_boards):
    for side in ("width", "height"):
        values = [getattr(b, side) / 1e6 for b in train_boards]
        assert 80 <= min(values) and max(values) <= 120
        assert abs(sum(values) / N_TRAIN - 100) < 5 * (40 / math.sqrt(12)) / math.sqrt(N_TRAIN)
        below_90 = sum(v < 90 for v in values) / N_TRAIN
        assert abs(below_90 - 0.25) < _tolerance(0.25, N_TRAIN)


def test_pad_kinds_and_layers_follow_the_fractions(train_boards):
    pads = [p for b in train_boards for p in b.pads]
    through = sum(p.kind == "thru_round" for p in pads)
    assert abs(through / len(pads) - 0.3) < _tolerance(0.3, len(pads))
    smd = [p for p in pads if p.kind == "smd_roundrect"]
    assert len(smd) + through == len(pads)
    back = sum(p.layer == "B.Cu" for p in smd)
    assert abs(back / len(smd) - 0.5) < _tolerance(0.5, len(smd))


def test_pads_are_on_the_lattice_inside_the_central_area_and_apart(train_boards):
    lattice, spacing = mm_to_nm(0.6), mm_to_nm(4.8)
    for board in train_boards[:2000]:
        for k, pad in enumerate(board.pads):
            assert pad.x % lattice == 0 and pad.y % lattice == 0
            assert 0.05 * board.width <= pad.x <= 0.95 * board.width
            assert 0.05 * board.height <= pad.y <= 0.95 * board.height
            for other in board.pads[:k]:
                assert (pad.x - other.x) ** 2 + (pad.y - other.y) ** 2 >= spacing ** 2


def test_files_carry_the_pad_shapes_and_rules(tmp_path):
    board = D2Generator(D2Params()).generate(0, "test", 0).board
    path = write_board(tmp_path, board)
    for pad in pads_in_file(path):
        assert pad["size"] == (2.4, 2.4)
        if pad["type"] == "thru_hole":
            assert (pad["shape"], pad["drill"]) == ("circle", 0.6)
            assert pad["layers"] == ["*.Cu", "*.Mask"]
        else:
            assert pad["shape"] == "roundrect" and pad["layers"][0] in ("F.Cu", "B.Cu")
            assert pad["footprint_layer"] == pad["layers"][0]
    assert "(roundrect_rratio 0.25)" in path.read_text()
    project = json.loads((tmp_path / "board.kicad_pro").read_text())
    netclass = project["net_settings"]["classes"][0]
    assert (netclass["clearance"], netclass["track_width"]) == (0.3, 0.3)
    assert (netclass["via_diameter"], netclass["via_drill"]) == (1.2, 0.6)
    assert project["board"]["design_settings"]["rules"]["min_copper_edge_clearance"] == 0.3
    assert not (tmp_path / "board.kicad_dru").exists()


def test_every_level_has_boards_that_pass_drc_with_only_unconnected_items(kicad_pool, tmp_path):
    jobs = []
    for name in preset_levels("d2"):
        generator = D2Generator(preset_level("d2", name).params)
        for index in range(6):
            board = generator.generate(0, "test", index).board
            path = write_board(tmp_path / f"{name}-{index}", board)
            jobs.append((str(path), board.missing_connections))
    for outcome in kicad_pool.map("pcbdata.kicad.basics:drc", [(p,) for p, _ in jobs]):
        report = DrcReport.from_dict(outcome.value)
        assert report.counts_by_type() == {"unconnected_items": jobs[outcome.index][1]}


def test_levels_get_harder_by_rank_in_nets_pads_size_and_spacing():
    levels = sorted((preset_level("d2", name) for name in preset_levels("d2")),
                    key=lambda level: level.rank)
    assert levels[0].name == "default" and levels[0].params == D2Params()
    assert len(levels) >= 4
    for easier, harder in zip(levels, levels[1:]):
        e, h = easier.params, harder.params
        mean_pads = lambda p: (sum(p.net_counts) / len(p.net_counts)) * sum(  # noqa: E731
            int(k) * v for k, v in p.pads_per_net.items())
        assert mean_pads(h) > mean_pads(e)
        assert max(h.net_counts) > max(e.net_counts)
        assert h.width_mm[1] < e.width_mm[1] and h.height_mm[1] < e.height_mm[1]
        assert h.min_pad_spacing_mm < e.min_pad_spacing_mm
        assert harder.rank == easier.rank + 1
        assert harder.description and harder.description != easier.description


def test_unknown_level_suggests_the_closest():
    with pytest.raises(UserError, match="did you mean 'medium'"):
        preset_level("d2", "meduim")


def test_unknown_parameter_suggests_the_closest():
    with pytest.raises(UserError, match="did you mean 'min_pad_spacing_mm'"):
        preset_level("d2", "default", {"min_pad_spacing": 4.0})


@pytest.mark.parametrize("override, message", [
    ({"net_counts": [0]}, "net_counts"),
    ({"net_counts": []}, "net_counts"),
    ({"net_counts": [40], "pads_per_net": {"5": 1.0}}, "pads per board"),
    ({"pads_per_net": {"2": 0.5, "3": 0.4}}, "sum to 1"),
    ({"min_pad_spacing_mm": 2.5}, "clearance"),
    ({"width_mm": [120, 80]}, "width_mm"),
    ({"pad_size_mm": "big"}, "must be a number"),
    ({"net_counts": [4.5]}, "list of integers"),
])
def test_impossible_parameters_are_rejected_with_the_reason(override, message):
    with pytest.raises(UserError, match=message):
        preset_level("d2", "default", override)


def test_override_values_are_parsed_as_toml():
    assert parse_override("net_counts=[6,7]") == ("net_counts", [6, 7])
    assert parse_override("pads_per_net={2=0.5,3=0.5}") == ("pads_per_net", {"2": 0.5, "3": 0.5})
    assert parse_override("min_pad_spacing_mm = 4.2") == ("min_pad_spacing_mm", 4.2)
    with pytest.raises(UserError, match="not a number"):
        parse_override("min_pad_spacing_mm=abc")
    with pytest.raises(UserError, match="expected key=value"):
        parse_override("min_pad_spacing_mm")


def test_a_board_that_cannot_be_placed_is_an_error_not_a_hang():
    # Valid parameters stay under a conservative capacity bound; the placer itself must still
    # give up after a bounded number of tries when asked for more pads than can fit.
    import time

    from pcbdata.core.rng import Stream

    generator = D2Generator(D2Params())
    start = time.perf_counter()
    with pytest.raises(GenerationError, match="could not place 400 pads 4.8 mm apart"):
        generator._place(Stream(0, 2, 0, "test", 0), mm_to_nm(80), mm_to_nm(80), 400, "test", 0)
    assert time.perf_counter() - start < 60

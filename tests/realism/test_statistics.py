"""The statistics of SPEC 2b on boards whose answers are known, and the KS distance."""
from __future__ import annotations

import math
from collections import Counter

import pytest

from pcbdata.realism.statistics import (
    BoardStatistics,
    board_statistics,
    ks_distance,
    parse_sexpr,
    pooled_samples,
    statistics_of,
    summary,
    weighted_samples,
)

# A 40 x 30 mm board with a 10 x 10 notch out of its top-right corner, a rounded (r = 5)
# bottom-left corner, a 2 mm radius hole, and a rectangular 2 x 4 mm slot drawn inside a
# footprint turned by 90 degrees (so it lies 4 mm along x on the board).
OUTLINE = """
  (gr_line (start 5 0) (end 30 0) (layer "Edge.Cuts"))
  (gr_line (start 30 0) (end 30 10) (layer "Edge.Cuts"))
  (gr_line (start 30 10) (end 40 10) (layer "Edge.Cuts"))
  (gr_line (start 40 10) (end 40 30) (layer "Edge.Cuts"))
  (gr_line (start 40 30) (end 0 30) (layer "Edge.Cuts"))
  (gr_line (start 0 30) (end 0 5) (layer "Edge.Cuts"))
  (gr_arc (start 0 5) (mid 1.464466 1.464466) (end 5 0) (layer "Edge.Cuts"))
  (gr_circle (center 20 20) (end 22 20) (layer "Edge.Cuts"))
  (gr_text "not an outline" (at 1 1) (layer "F.SilkS"))
"""
NOTCHED_AREA = 40 * 30 - 10 * 10 - (25 - math.pi * 25 / 4) - math.pi * 4 - 8

FOOTPRINTS = """
  (footprint "SOT23" (layer "F.Cu") (at 10 20 90)
    (pad "1" smd rect (at -0.95 1) (size 0.6 0.7) (layers "F.Cu" "F.Mask") (net 1 "GND"))
    (pad "2" smd rect (at 0.95 1) (size 0.6 0.7) (layers "F.Cu" "F.Mask") (net 2 "SIG"))
    (pad "3" smd rect (at 0 -1) (size 0.6 0.7) (layers "F.Cu" "F.Mask") (net 3 "ALONE"))
    (pad "" smd rect (at 0 -1) (size 0.4 0.4) (layers "F.Paste") (net 1 "GND")))
  (footprint "R0805" (layer "B.Cu") (at 20 10 180)
    (pad "1" smd rect (at -1 0) (size 1 1.3) (layers "B.Cu" "B.Mask") (net 1 "GND"))
    (pad "2" smd rect (at 1 0) (size 1 1.3) (layers "B.Cu" "B.Mask") (net 2 "SIG")))
  (footprint "Header3" (layer "F.Cu") (at 30 25)
    (pad "1" thru_hole rect (at 0 0) (size 1.7 1.7) (drill 1) (layers "*.Cu" "*.Mask")
      (net 1 "GND"))
    (pad "2" thru_hole oval (at 2.54 0) (size 1.7 1.7) (drill 1) (layers "*.Cu" "*.Mask")
      (net 2 "SIG"))
    (pad "3" thru_hole oval (at 5.08 0) (size 1.7 1.7) (drill 1) (layers "*.Cu" "*.Mask")))
  (footprint "MountingHole" (layer "F.Cu") (at 5 25)
    (pad "" np_thru_hole circle (at 0 0) (size 3 3) (drill 3) (layers "*.Cu" "*.Mask"))
    (pad "" np_thru_hole circle (at 1 0) (size 3 3) (drill 3) (layers "*.Cu" "*.Mask")))
  (footprint "Slot" (layer "F.Cu") (at 12 8 90)
    (fp_rect (start -1 -2) (end 1 2) (layer "Edge.Cuts")))
"""

LAYERS = """
  (layers (0 "F.Cu" signal) (4 "In1.Cu" signal) (6 "In2.Cu" signal) (2 "B.Cu" signal)
    (25 "Edge.Cuts" user) (5 "F.SilkS" user "F.Silkscreen"))
"""


def _board(body: str) -> str:
    return f'(kicad_pcb (version 20241229) (generator "test")\n{LAYERS}{body})\n'


def test_a_notched_board_with_multi_pad_footprints():
    stats = statistics_of(parse_sexpr(_board(OUTLINE + FOOTPRINTS)))
    # GND: SOT23.1, R.1, header.1 (the paste-only aperture is no pad); SIG: SOT23.2, R.2,
    # header.2; ALONE (one pad) and the header's unconnected pin 3 are not terminals.
    assert (stats.nets, stats.pads, stats.pads_per_net) == (2, 6, (3, 3))
    assert stats.components == 5
    assert stats.layers == 4
    assert stats.outline_area_mm2 == pytest.approx(NOTCHED_AREA, rel=2e-3)
    assert stats.pad_density == pytest.approx(6 / (NOTCHED_AREA / 100), rel=2e-3)
    # SOT23: min(1.9, hypot(0.95, 2)) = 1.9; R0805: 2.0; header: 2.54; mounting hole: NPTH.
    assert sorted(stats.footprint_pitches) == pytest.approx([1.9, 2.0, 2.54])
    assert stats.pad_pitch == pytest.approx(2.0)


def test_equal_pitches_are_equal_values_whatever_the_coordinates():
    """10.16 - 7.62 is 2.5400000000000009 in floating point: unrounded, two boards with 2.54 mm
    parts would give distinct pitches and a KS distance between equal distributions."""
    shifted = """
  (footprint "Axial" (layer "F.Cu") (at 10 10)
    (pad "1" thru_hole circle (at 7.62 0) (size 1.6 1.6) (drill 0.8) (layers "*.Cu")
      (net 1 "A"))
    (pad "2" thru_hole circle (at 10.16 0) (size 1.6 1.6) (drill 0.8) (layers "*.Cu")
      (net 2 "B")))
  (footprint "Centred" (layer "F.Cu") (at 20 10)
    (pad "1" thru_hole circle (at -1.27 0) (size 1.6 1.6) (drill 0.8) (layers "*.Cu")
      (net 1 "A"))
    (pad "2" thru_hole circle (at 1.27 0) (size 1.6 1.6) (drill 0.8) (layers "*.Cu")
      (net 2 "B")))
"""
    stats = statistics_of(parse_sexpr(_board(OUTLINE + shifted)))
    assert stats.footprint_pitches == (2.54, 2.54)
    assert stats.pad_pitch == 2.54
    assert ks_distance([stats.pad_pitch], [2.54]) == 0


def test_an_outline_that_closes_nothing_has_no_density():
    open_outline = OUTLINE.replace('(gr_line (start 40 30) (end 0 30) (layer "Edge.Cuts"))', "")
    open_outline = open_outline.replace("gr_circle", "gr_text_box_not_drawn")
    stats = statistics_of(parse_sexpr(_board(open_outline + FOOTPRINTS)))
    assert stats.outline_area_mm2 == pytest.approx(8)  # only the slot closes
    no_edges = statistics_of(parse_sexpr(_board(FOOTPRINTS.split('(footprint "Slot"')[0])))
    assert no_edges.outline_area_mm2 is None and no_edges.pad_density is None
    assert no_edges.values()["pad_density"] == []


def test_a_generated_d2_board(tmp_path):
    from pcbdata.sets.configs import get_config
    from pcbdata.testing.sets import write_board

    spec = get_config("d2")
    board = spec.generator().generate(spec.seed, "test", 3).board
    stats = board_statistics(write_board(tmp_path, board))
    per_net = Counter(p.net for p in board.pads)
    assert stats.pads_per_net == tuple(sorted(n for n in per_net.values() if n >= 2))
    assert stats.pads == board.n_pads and stats.nets == len(stats.pads_per_net)
    assert stats.components == len(board.pads)
    assert stats.layers == 2
    assert stats.outline_area_mm2 == pytest.approx(board.width * board.height / 1e12)
    assert stats.pad_pitch is None  # D2 places single-pad footprints only


def test_pooled_samples_take_every_net_but_one_value_per_board():
    one = statistics_of(parse_sexpr(_board(OUTLINE + FOOTPRINTS)))
    pooled = pooled_samples([one, one])
    assert pooled["pads_per_net"] == [3.0, 3.0, 3.0, 3.0]
    assert pooled["nets"] == [2.0, 2.0]


def test_ks_distance():
    assert ks_distance([1, 2, 3, 3, 7], [7, 3, 2, 3, 1]) == 0.0
    assert ks_distance([1, 2, 3], [4, 5]) == 1.0
    assert ks_distance([1, 2, 3, 4], [3, 4, 5, 6]) == 0.5
    assert ks_distance([2, 2, 2, 3], [2, 3, 3, 3]) == 0.5  # ties: the CDFs jump together
    assert ks_distance([], [1]) is None


def test_weighted_ks_distance_is_the_repeated_sample_s():
    """A weight of k counts a value k times; equal weights change nothing."""
    import random

    rng = random.Random(7)
    for _ in range(50):
        a = [rng.randint(0, 9) for _ in range(rng.randint(1, 12))]
        b = [rng.randint(0, 9) for _ in range(rng.randint(1, 12))]
        counts = [rng.randint(0, 3) for _ in a]
        counts[0] = max(counts[0], 1)
        repeated = [x for x, k in zip(a, counts) for _ in range(k)]
        assert ks_distance(a, b, counts) == pytest.approx(ks_distance(repeated, b), abs=1e-12)
        assert ks_distance(a, b, [0.5] * len(a), [2.0] * len(b)) == pytest.approx(
            ks_distance(a, b), abs=1e-12)
    with pytest.raises(ValueError, match="one non-negative number per value"):
        ks_distance([1, 2], [3], [1.0])
    with pytest.raises(ValueError, match="not all 0"):
        ks_distance([1, 2], [3], [0.0, 0.0])


def test_weighted_samples_give_each_net_its_board_s_weight():
    one = BoardStatistics(nets=2, pads=5, components=2, layers=2, pads_per_net=(2, 3),
                          outline_area_mm2=100.0)
    two = BoardStatistics(nets=1, pads=2, components=1, layers=4, pads_per_net=(2,),
                          outline_area_mm2=None)
    samples = weighted_samples([one, two], [1.0, 0.25])
    assert samples["pads_per_net"] == ([2.0, 3.0, 2.0], [1.0, 1.0, 0.25])
    assert samples["pad_density"] == ([5.0], [1.0])  # no outline, no density
    assert samples["layers"] == ([2.0, 4.0], [1.0, 0.25])
    assert samples["two_pad_net_share"] == ([0.5, 1.0], [1.0, 0.25])


def test_summary_quantiles():
    out = summary(list(range(1, 102)))
    assert out["count"] == 101 and out["mean"] == 51
    assert out["quantiles"]["5"] == 6 and out["quantiles"]["50"] == 51
    assert summary([])["count"] == 0


#: PCBench boards of several sizes, formats and layer counts (bikedar: 4 layers).
PCBENCH_BOARDS = ("bikedar_bikedar", "Biscay_Blueeye_mcu", "BB-PWR-8113_BB-PWR-8113_revA",
                  "mechkeys_LFK78", "kitspace_bomanz")


@pytest.fixture(scope="module")
def pcbench_boards(tmp_path_factory):
    import subprocess

    from tests.conftest import SHARED_PCBENCH
    from tests.helpers import skip_without_snapshot

    if not SHARED_PCBENCH.is_file():
        skip_without_snapshot(f"needs the PCBench snapshot at {SHARED_PCBENCH} (absent on this "
                              f"machine)")
    root = tmp_path_factory.mktemp("pcbench-few")
    members = [f"PCBs/{name}/*" for name in PCBENCH_BOARDS]
    subprocess.run(["tar", "-xJf", str(SHARED_PCBENCH), "-C", str(root), "--wildcards",
                    *members], check=True)
    return root / "PCBs"


def test_nets_and_pads_count_as_pcbench_final_json(pcbench_boards):
    """D3's characteristics.csv takes nets and pads from `final.json`; the board file gives
    the same counts, but where PCBench lists copper-less aperture pads under a net."""
    import json

    for name in PCBENCH_BOARDS:
        nets = json.loads((pcbench_boards / name / "final.json").read_text())["nets"]
        stats = board_statistics(pcbench_boards / name / "processed.kicad_pcb")
        copper = [[p for p in pads if p["layer"]] for pads in nets.values()]
        assert stats.nets == len(nets), name
        assert stats.pads == sum(map(len, copper)), name
        assert stats.pads_per_net == tuple(sorted(map(len, copper))), name
    assert board_statistics(pcbench_boards / "bikedar_bikedar" / "processed.kicad_pcb").layers == 4


def test_net_shapes_are_per_board_shares_of_two_pad_nets_and_of_the_largest_net():
    from pcbdata.realism.statistics import BoardStatistics, net_shape_samples

    def board(*sizes: int) -> BoardStatistics:
        return BoardStatistics(nets=len(sizes), pads=sum(sizes), components=3, layers=2,
                               pads_per_net=tuple(sizes), outline_area_mm2=100.0)

    shapes = net_shape_samples([board(2, 2, 2, 6), board(), board(3, 3)])
    assert shapes == {"two_pad_net_share": [0.75, 0.0], "largest_net_share": [0.5, 0.5]}

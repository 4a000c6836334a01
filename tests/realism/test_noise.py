"""The noise floor of SPEC 2b's distances and of its classifier test (pcbdata.realism.noise)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from pcbdata.realism.classifier import features
from pcbdata.realism.noise import (
    ClassifierFloor,
    Smoother,
    calibration_copy_aucs,
    calibration_copy_distances,
    perfect_generator_distances,
    real_split_aucs,
)
from pcbdata.realism.statistics import STATISTICS, BoardStatistics


def _board(components: int = 5, area_mm2: float | None = 100.0,
           pitches: tuple[float, ...] = (2.54,), pads: int = 10) -> BoardStatistics:
    return BoardStatistics(nets=pads // 2, pads=pads, components=components, layers=2,
                           pads_per_net=(2,) * (pads // 2), outline_area_mm2=area_mm2,
                           footprint_pitches=pitches)


def _kolmogorov_tail(x: float) -> float:
    return 2 * sum((-1) ** (k - 1) * math.exp(-2 * k * k * x * x) for k in range(1, 101))


def test_a_perfect_generator_exceeds_a_distance_as_often_as_kolmogorov_says():
    rng = np.random.default_rng(7)
    population = [_board(area_mm2=float(a)) for a in rng.uniform(50, 5000, size=4000)]
    floor = perfect_generator_distances(population, held_out_size=50, synthetic_size=512,
                                        draws=600, seed=1)
    expected = _kolmogorov_tail(0.15 * math.sqrt(50 * 512 / 562))  # about 0.26
    assert abs(floor.share_above(0.15, "pad_density") - expected) < 0.07
    assert floor.share_above(0.15, "layers") == 0.0  # every board has 2 layers
    assert floor.share_above(0.15) == floor.share_above(0.15, "pad_density")


def test_a_copy_of_the_calibration_half_on_the_spec_split_sees_only_the_odd_rows():
    # odd row numbers (calibration) have 2 parts, even rows 10: the SPEC's halves disagree
    # completely, random pads-interleaved splits mostly do not
    tier = [_board(components=2 if row % 2 else 10) for row in range(1, 101)]
    spec = calibration_copy_distances(tier, draws=50, split="spec")
    assert np.all(spec.distances["components"] == 1.0)
    assert spec.held_out_size == 50
    shuffled = calibration_copy_distances(tier, draws=200)
    assert shuffled.quantile("components", 50) < 0.25
    assert shuffled.rank("components", 0.5) > 0.95


def test_an_odd_tier_keeps_its_last_row_in_the_calibration_half():
    tier = [_board(components=3)] * 4 + [_board(components=40)]
    floor = calibration_copy_distances(tier, draws=30, split="spec")
    # the synthetic side draws from rows 1, 3, 5 (5 has 40 parts), the held-out half never
    assert floor.held_out_size == 2
    assert floor.quantile("components", 50) > 0.2


def test_draws_repeat_for_a_seed_and_differ_across_seeds():
    rng = np.random.default_rng(3)
    tier = [_board(components=int(c), area_mm2=float(a))
            for c, a in zip(rng.integers(2, 30, 80), rng.uniform(100, 900, 80))]
    one = calibration_copy_distances(tier, draws=40, seed=5)
    again = calibration_copy_distances(tier, draws=40, seed=5)
    other = calibration_copy_distances(tier, draws=40, seed=6)
    assert all(np.array_equal(one.distances[n], again.distances[n]) for n in one.distances)
    assert not np.array_equal(one.distances["pad_density"], other.distances["pad_density"])


def test_a_statistic_no_board_has_is_left_out_not_counted():
    tier = [_board(pitches=(), components=c) for c in (2, 9) * 20]
    floor = calibration_copy_distances(tier, draws=20)
    assert np.all(np.isnan(floor.distances["pad_pitch"]))
    assert floor.share_above(0.0, "pad_pitch") == 0.0
    assert floor.draws == 20


def test_bad_arguments_are_errors_that_say_so():
    with pytest.raises(ValueError, match="at least two real boards"):
        perfect_generator_distances([], held_out_size=5)
    with pytest.raises(ValueError, match="at least two real boards"):
        calibration_copy_distances([_board()])
    with pytest.raises(ValueError, match="'random' or 'spec'"):
        calibration_copy_distances([_board()] * 4, split="even")


# --- the classifier test's floor ------------------------------------------------------

def _varied_board(rng: np.random.Generator, scale: float = 1.0) -> BoardStatistics:
    nets = int(rng.integers(5, 60) * scale)
    sizes = tuple(int(n) for n in rng.integers(2, 5, size=nets))
    return BoardStatistics(nets=nets, pads=sum(sizes), components=int(rng.integers(2, 40)),
                           layers=int(rng.choice([2, 4])), pads_per_net=sizes,
                           outline_area_mm2=float(rng.uniform(300, 9000)),
                           footprint_pitches=(float(rng.choice([1.27, 2.54])),
                                              float(rng.uniform(0.4, 5.0))))


def _column(rows: np.ndarray, name: str) -> np.ndarray:
    return rows[:, STATISTICS.index(name)]


def test_the_smoother_leaves_no_duplicate_board_and_keeps_boards_consistent():
    rng = np.random.default_rng(0)
    reference = features([_varied_board(rng) for _ in range(80)]
                         + [_board(pitches=(2.54,)), _board(pitches=(2.54,)),
                            _board(pitches=(), area_mm2=None)])
    smoother = Smoother(reference)
    density = _column(reference, "pad_density")
    logs = np.log(density[np.isfinite(density)])
    iqr = np.subtract(*np.percentile(logs, [75, 25]))
    silverman = 0.9 * min(np.std(logs, ddof=1), iqr / 1.34) * logs.size ** -0.2
    assert smoother.bandwidths["pad_density"] == pytest.approx(silverman)
    assert 2.54 in smoother.shared_pitches
    assert "layers" not in smoother.bandwidths and "pads" not in smoother.bandwidths

    copies = reference[np.repeat(np.arange(len(reference)), 3)]  # every board three times
    moved = smoother(copies, np.random.default_rng(1))
    finite = moved[np.all(np.isfinite(moved), axis=1)]
    assert len(np.unique(finite, axis=0)) == len(finite)  # no two rows alike
    for name in ("nets", "pads", "components"):  # counts stay whole
        assert np.array_equal(_column(moved, name), np.rint(_column(moved, name)))
    nets, pads = _column(moved, "nets"), _column(moved, "pads")
    assert np.all(pads >= 2 * nets)
    assert np.allclose(_column(moved, "pads_per_net"), pads / nets)
    # pads follow nets and pads per net: a board's pads per net spreads by its own kernel only
    spread = np.std(np.log(_column(moved, "pads_per_net") / _column(copies, "pads_per_net")))
    assert spread < 1.5 * smoother.bandwidths["pads_per_net"]
    assert np.array_equal(_column(moved, "layers"), _column(copies, "layers"))
    before, after = _column(copies, "pad_pitch"), _column(moved, "pad_pitch")
    shared = np.isin(before, smoother.shared_pitches)  # land-pattern values stay
    assert np.array_equal(after[shared], before[shared])
    others = ~shared & np.isfinite(before)
    assert others.any() and not np.any(after[others] == before[others])
    density = _column(moved, "pad_density")
    assert np.array_equal(np.isnan(density), np.isnan(_column(copies, "pad_density")))
    assert np.nanmin(density) >= np.nanmin(_column(reference, "pad_density")) - 1e-9
    assert np.nanmax(density) <= np.nanmax(_column(reference, "pad_density")) + 1e-9


def test_a_copy_of_a_calibration_half_unlike_the_held_out_half_is_told_apart():
    pytest.importorskip("sklearn")
    rng = np.random.default_rng(2)
    # odd rows (calibration) have boards four times the nets of the even rows (held out)
    tier = [_varied_board(rng, 4.0 if row % 2 else 1.0) for row in range(1, 61)]
    mask = [row % 2 == 1 for row in range(1, 61)]
    apart = calibration_copy_aucs(tier, mask, draws=1, samples=2, smoothing=1.0)
    assert apart.aucs.shape == (1, 2) and apart.held_out_size == 30
    assert apart.mean > 0.9 and apart.share_above(0.65) == 1.0
    again = calibration_copy_aucs(tier, mask, draws=1, samples=2, smoothing=1.0)
    assert np.array_equal(apart.aucs, again.aucs)
    # over random halves the two kinds of board mix: the copy is hard to tell apart
    mixed = calibration_copy_aucs(tier, mask, split="random", draws=3, samples=1,
                                  smoothing=1.0)
    assert mixed.mean < 0.8


def test_interleaved_real_halves_fall_below_the_permutation_null():
    """Boards that come in near-identical pairs (as a tier's boards in pads order do), split one
    of each pair to each half: the cross-validated classifier calls a board by its twin on the
    other side, AUC far below 0.5. Labels shuffled over the tier: about 0.5."""
    pytest.importorskip("sklearn")
    rng = np.random.default_rng(3)
    tier = [board for _ in range(30) for board in [_varied_board(rng)] * 2]
    mask = [row % 2 == 1 for row in range(1, 61)]
    spec = real_split_aucs(tier, mask, split="spec", draws=2)
    interleaved = real_split_aucs(tier, mask, split="interleaved", draws=3)
    null = real_split_aucs(tier, mask, split="random", draws=6)
    assert spec.mean < 0.3 and interleaved.mean < 0.3
    assert 0.35 < null.mean < 0.65
    assert null.aucs.shape == (6, 1)


def test_a_classifier_floor_summarises_draws_by_their_means():
    floor = ClassifierFloor(50, np.array([[0.6, 0.8], [0.5, 0.6], [0.7, 0.7]]))
    assert floor.draws == 3 and floor.samples == 2
    assert np.allclose(floor.draw_means, [0.7, 0.55, 0.7])
    assert floor.share_above(0.65) == pytest.approx(2 / 3)
    assert floor.sample_share_above(0.65) == pytest.approx(0.5)
    assert floor.mean == pytest.approx(0.65)
    assert floor.rank(0.6) == pytest.approx(1 / 3)


def test_classifier_floor_arguments_are_checked():
    tier = [_board(components=c) for c in range(40)]
    mask = [i % 2 == 0 for i in range(40)]
    with pytest.raises(ValueError, match="split is one of"):
        calibration_copy_aucs(tier, mask, split="even")
    with pytest.raises(ValueError, match="one calibration flag per board"):
        real_split_aucs(tier, mask[:-1])
    with pytest.raises(ValueError, match="at least 10 boards a half"):
        real_split_aucs(tier[:18], mask[:18])

"""The noise floor of SPEC 2b's distances (pcbdata.realism.noise)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from pcbdata.realism.noise import (
    calibration_copy_distances,
    perfect_generator_distances,
)
from pcbdata.realism.statistics import BoardStatistics


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

"""How far from a held-out half sampling alone puts a generator: SPEC 2b's distances as noise.

SPEC 2b fits a level on a tier's odd rows (in D3's table order: pads, nets, components) and
measures it against the even rows. On a tier of 100 boards each half has 50, and the
Kolmogorov-Smirnov distance of 50 real boards to 512 synthetic ones moves a lot by chance.
Two simulations say how much, each a `NoiseFloor` of distances per statistic and draw:

- `calibration_copy_distances`: the best a fit on the calibration half can do without
  knowledge from elsewhere is to reproduce that half. Each draw splits the real tier as the
  SPEC does, but at random (each consecutive pair of rows in table order gives one board to
  each half, so pads stay interleaved), draws the synthetic set from the calibration half
  (with replacement) and measures it against the held-out half. The SPEC's own split is one
  of these; `split=` pins it.
- `perfect_generator_distances`: a generator whose boards follow the real distribution: the
  held-out half and the synthetic set are drawn independently, with replacement, from a
  population of real boards. Held-out boards are drawn without the pads interleaving, so the
  distances of pads and nets (which the interleaving nearly fixes) come out larger than the
  SPEC's measure would give.

Distances are `board_statistics.ks_distance` on pooled samples, as the bench measures a level.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pcbdata.realism.statistics import STATISTICS, BoardStatistics, ks_distance


@dataclass(frozen=True)
class NoiseFloor:
    """Per statistic, the distance of each simulated draw (NaN where a sample was empty)."""

    held_out_size: int
    synthetic_size: int
    distances: dict[str, np.ndarray]

    @property
    def draws(self) -> int:
        return len(self.distances[STATISTICS[0]])

    def share_above(self, target: float, name: str | None = None) -> float:
        """The share of draws whose distance exceeds `target` on `name` (None: on any
        statistic)."""
        names = list(STATISTICS) if name is None else [name]
        table = np.column_stack([self.distances[n] for n in names])
        return float(np.mean(np.any(np.nan_to_num(table, nan=0.0) > target, axis=1)))

    def quantile(self, name: str, q: float) -> float:
        return float(np.nanpercentile(self.distances[name], q))

    def rank(self, name: str, distance: float) -> float:
        """The share of draws at or below `distance` (0.5: where a typical draw lands)."""
        column = self.distances[name]
        return float(np.mean(column[~np.isnan(column)] <= distance))


def calibration_copy_distances(tier: Sequence[BoardStatistics], *, synthetic_size: int = 512,
                               draws: int = 1000, seed: int = 0,
                               split: str = "random") -> NoiseFloor:
    """A generator equal to the calibration half, against the held-out half, over `draws`
    splits of `tier` (its boards in table order). `split="random"`: each consecutive pair of
    rows sends one board to each half at random; `split="spec"`: always the SPEC's halves (odd
    rows calibrate), so only the synthetic draw varies."""
    if split not in ("random", "spec"):
        raise ValueError(f"calibration_copy_distances: split is 'random' or 'spec', not {split!r}")
    _check(len(tier) >= 2, synthetic_size, draws)
    boards = _BoardColumns(tier)
    rng = np.random.default_rng(seed)
    first_of_pair = np.arange(0, len(tier) - 1, 2)
    out = _empty(draws)
    for draw in range(draws):
        flip = rng.integers(2, size=first_of_pair.size) if split == "random" else 0
        calibration = first_of_pair + flip
        held_out = first_of_pair + 1 - flip
        if len(tier) % 2:  # the last row is odd: calibration, as in the SPEC's halves
            calibration = np.append(calibration, len(tier) - 1)
        synthetic = calibration[rng.integers(calibration.size, size=synthetic_size)]
        _record(out, draw, boards, held_out, synthetic)
    return NoiseFloor(first_of_pair.size, synthetic_size, out)


def perfect_generator_distances(population: Sequence[BoardStatistics], *, held_out_size: int,
                                synthetic_size: int = 512, draws: int = 1000,
                                seed: int = 0) -> NoiseFloor:
    """Held-out half and synthetic set drawn independently from `population` (module
    docstring); deterministic for a seed."""
    _check(bool(population) and held_out_size >= 1, synthetic_size, draws)
    boards = _BoardColumns(population)
    rng = np.random.default_rng(seed)
    out = _empty(draws)
    for draw in range(draws):
        held_out = rng.integers(len(population), size=held_out_size)
        synthetic = rng.integers(len(population), size=synthetic_size)
        _record(out, draw, boards, held_out, synthetic)
    return NoiseFloor(held_out_size, synthetic_size, out)


def _check(sizes_ok: bool, synthetic_size: int, draws: int) -> None:
    if not sizes_ok or synthetic_size < 1 or draws < 1:
        raise ValueError("sampling noise: need at least two real boards (one a half), "
                         "synthetic_size >= 1 and draws >= 1")


def _empty(draws: int) -> dict[str, np.ndarray]:
    return {name: np.empty(draws) for name in STATISTICS}


def _record(out: dict[str, np.ndarray], draw: int, boards: _BoardColumns,
            held_out: np.ndarray, synthetic: np.ndarray) -> None:
    for name in STATISTICS:
        distance = ks_distance(boards.sample(name, held_out), boards.sample(name, synthetic))
        out[name][draw] = np.nan if distance is None else distance


class _BoardColumns:
    """Each board's values per statistic, so that a draw is index arithmetic."""

    def __init__(self, boards: Sequence[BoardStatistics]) -> None:
        values = [one.values() for one in boards]
        self._per_board = {name: [np.asarray(v[name], dtype=float) for v in values]
                           for name in STATISTICS}

    def sample(self, name: str, picks: np.ndarray) -> np.ndarray:
        return np.concatenate([self._per_board[name][i] for i in picks])

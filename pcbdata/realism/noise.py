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

The joint test has its floor too, each a `ClassifierFloor` of cross-validated ROC AUCs
(`pcbdata.realism.classifier`, the test as the bench runs it on a level, without the
permutation importances, which do not change the AUC), per draw a split of the tier (`SPLITS`:
the SPEC's halves, random pads-interleaved ones, or any):

- `calibration_copy_aucs`: each level sample is a draw of the held-out half's size from the
  calibration half, with replacement, against the held-out half; `smoothing` moves each
  drawn board by a small kernel (`Smoother`), so that a board drawn twice is not two identical
  rows a tree can key on.
- `real_split_aucs`: the two halves against each other. Over random splits this is the
  permutation null (labels shuffled). The SPEC's halves and other pads-interleaved ones come
  out below it, under 0.5: every board has a neighbour in pads (and mostly in nets and parts)
  on the other side, and a cross-validated classifier, trained without the board, calls its
  neighbourhood the other class.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pcbdata.realism.classifier import FOLDS, feature_auc, features
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
    out = _empty(draws)
    for draw in range(draws):
        calibration, held_out = _interleaved_halves(len(tier), rng, split == "random")
        synthetic = calibration[rng.integers(calibration.size, size=synthetic_size)]
        _record(out, draw, boards, held_out, synthetic)
    return NoiseFloor(len(tier) // 2, synthetic_size, out)


def _interleaved_halves(rows: int, rng: np.random.Generator,
                        flip: bool) -> tuple[np.ndarray, np.ndarray]:
    """(calibration, held out) row indices: each consecutive pair of rows gives one row to
    each half, at random with `flip`, else as the SPEC's halves (odd row numbers calibrate;
    an odd last row too)."""
    first_of_pair = np.arange(0, rows - 1, 2)
    flips = rng.integers(2, size=first_of_pair.size) if flip else 0
    calibration, held_out = first_of_pair + flips, first_of_pair + 1 - flips
    if rows % 2:
        calibration = np.append(calibration, rows - 1)
    return calibration, held_out


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


# --- the classifier test's floor ------------------------------------------------------

#: How the classifier floors split a tier: the SPEC's halves as given, random
#: pads-interleaved halves (each consecutive pair of rows gives one board to each), or any
#: halves of the SPEC's sizes.
SPLITS = ("spec", "interleaved", "random")


@dataclass(frozen=True)
class ClassifierFloor:
    """The classifier test's cross-validated ROC AUC per draw (a split of the tier) and level
    sample of that draw: `aucs[draw, sample]`. SPEC 2b's figure is the mean over a draw's
    samples."""

    held_out_size: int
    aucs: np.ndarray

    @property
    def draws(self) -> int:
        return self.aucs.shape[0]

    @property
    def samples(self) -> int:
        return self.aucs.shape[1]

    @property
    def draw_means(self) -> np.ndarray:
        return self.aucs.mean(axis=1)

    @property
    def mean(self) -> float:
        return float(self.aucs.mean())

    @property
    def std(self) -> float:
        """The spread of one sample's AUC (as the bench reports a level's)."""
        return float(np.std(self.aucs, ddof=1)) if self.aucs.size > 1 else 0.0

    def quantile(self, q: float) -> float:
        """Of the draws' means."""
        return float(np.percentile(self.draw_means, q))

    def share_above(self, target: float) -> float:
        """The share of draws whose mean AUC exceeds `target`."""
        return float(np.mean(self.draw_means > target))

    def sample_share_above(self, target: float) -> float:
        """The share of single samples whose AUC exceeds `target`."""
        return float(np.mean(self.aucs > target))

    def rank(self, auc: float) -> float:
        """The share of draws whose mean is at or below `auc`."""
        return float(np.mean(self.draw_means <= auc))


#: What `Smoother` moves: the counts (rounded back), pads per net (the board's mean), pad
#: density, and pad pitch off the values two or more reference boards share; pads follow
#: as nets x pads per net, layers stay.
SMOOTHED = ("nets", "components", "pads_per_net", "pad_density", "pad_pitch")
_COUNTS = ("nets", "components")


class Smoother:
    """A smoothed bootstrap's kernel, fitted on a reference sample (`features` rows): each
    statistic of `SMOOTHED` moves in log space by a normal draw of standard deviation h =
    `scale` x Silverman's rule on the reference's logs, 0.9 min(sd, IQR / 1.34) n^(-1/5),
    reflected at the reference's smallest and largest log. Nets and components are rounded
    back to integers (at least 1); pads become nets x the moved pads per net, reflected at the
    reference's smallest and largest pads, rounded, at least 2 per net; pads per net is then
    pads / nets again (as on a real board: moving pads and nets each on its own would widen
    pads per net by both kernels). A pad pitch that two or more reference boards share (a land
    pattern's value, 2.54 mm) stays, other pitches move; layers stay; undefined values stay
    undefined."""

    def __init__(self, reference: np.ndarray, scale: float = 1.0) -> None:
        self.bandwidths: dict[str, float] = {}
        self._bounds: dict[str, tuple[float, float]] = {}
        for name in (*SMOOTHED, "pads"):
            column = reference[:, STATISTICS.index(name)]
            logs = np.log(column[np.isfinite(column) & (column > 0)])
            if logs.size < 2:
                continue
            self._bounds[name] = (float(logs.min()), float(logs.max()))
            if name in SMOOTHED:
                iqr = float(np.subtract(*np.percentile(logs, [75, 25])))
                sd = float(np.std(logs, ddof=1))
                spread = min(sd, iqr / 1.34) if iqr > 0 else sd
                self.bandwidths[name] = scale * 0.9 * spread * logs.size ** -0.2
        pitch = reference[:, STATISTICS.index("pad_pitch")]
        values, counts = np.unique(pitch[np.isfinite(pitch)], return_counts=True)
        self.shared_pitches = values[counts >= 2]

    def __call__(self, rows: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        out = rows.copy()
        for name, h in self.bandwidths.items():
            column = out[:, STATISTICS.index(name)]
            moves = np.isfinite(column) & (column > 0)
            if name == "pad_pitch":
                moves &= ~np.isin(column, self.shared_pitches)
            y = np.log(column[moves]) + rng.normal(0.0, h, size=int(moves.sum()))
            column[moves] = np.exp(self._reflect(name, y))
            if name in _COUNTS:
                column[moves] = np.maximum(np.rint(column[moves]), 1)
        nets, pads, per_net = (out[:, STATISTICS.index(n)] for n in
                               ("nets", "pads", "pads_per_net"))
        moved = np.isfinite(nets) & (nets > 0) & np.isfinite(per_net) & (per_net > 0)
        if "pads" in self._bounds:
            y = self._reflect("pads", np.log(nets[moved] * per_net[moved]))
            pads[moved] = np.maximum(np.rint(np.exp(y)), 2 * nets[moved])
        per_net[moved] = pads[moved] / nets[moved]
        return out

    def _reflect(self, name: str, y: np.ndarray) -> np.ndarray:
        low, high = self._bounds[name]
        y = np.where(y > high, 2 * high - y, y)
        return np.clip(np.where(y < low, 2 * low - y, y), low, high)


def calibration_copy_aucs(tier: Sequence[BoardStatistics], calibration: Sequence[bool], *,
                          split: str = "spec", draws: int = 10, samples: int = 20,
                          seed: int = 0, smoothing: float = 0.0) -> ClassifierFloor:
    """The classifier test of a generator equal to the calibration half. `tier`: the boards in
    table order; `calibration`: per row, whether it is in the SPEC's calibration half. Per
    draw the tier is split (`SPLITS`; "spec" keeps the SPEC's halves, so only the level
    samples vary), and each of `samples` level samples is a draw of the held-out half's size
    from the calibration half with replacement (`smoothing` > 0: each board moved by a
    `Smoother` fitted on that calibration half, its bandwidths `smoothing` x Silverman's),
    tested against the held-out half with folds and model seeded by `seed` + its index.
    Deterministic for a seed."""
    rows, mask, rng = _classifier_setup(tier, calibration, split, draws, samples, seed)
    aucs = np.empty((draws, samples))
    for draw in range(draws):
        cal, held_out = _split(mask, split, rng)
        ours, real = rows[cal], rows[held_out]
        smoother = Smoother(ours, smoothing) if smoothing > 0 else None
        for k in range(samples):
            sample = ours[rng.integers(len(ours), size=len(real))]
            if smoother is not None:
                sample = smoother(sample, rng)
            aucs[draw, k] = feature_auc(real, sample, seed + draw * samples + k,
                                        importance=False)[0]
    return ClassifierFloor(int((~mask).sum()), aucs)


def real_split_aucs(tier: Sequence[BoardStatistics], calibration: Sequence[bool], *,
                    split: str = "random", draws: int = 100,
                    seed: int = 0) -> ClassifierFloor:
    """The classifier test of the tier's two halves against each other (held-out side against
    calibration side; arguments as `calibration_copy_aucs`), one AUC per draw. "random" is the
    permutation null (labels shuffled over the tier, the SPEC's half sizes); "spec" the SPEC's
    halves themselves, only the folds and model seed varying."""
    rows, mask, rng = _classifier_setup(tier, calibration, split, draws, 1, seed)
    aucs = np.empty((draws, 1))
    for draw in range(draws):
        cal, held_out = _split(mask, split, rng)
        aucs[draw, 0] = feature_auc(rows[held_out], rows[cal], seed + draw,
                                    importance=False)[0]
    return ClassifierFloor(int((~mask).sum()), aucs)


def _classifier_setup(tier: Sequence[BoardStatistics], calibration: Sequence[bool],
                      split: str, draws: int, samples: int,
                      seed: int) -> tuple[np.ndarray, np.ndarray, np.random.Generator]:
    if split not in SPLITS:
        raise ValueError(f"classifier floor: split is one of {SPLITS}, not {split!r}")
    mask = np.asarray(calibration, dtype=bool)
    if mask.shape != (len(tier),):
        raise ValueError("classifier floor: one calibration flag per board of the tier")
    side = min(int(mask.sum()), int((~mask).sum()), len(tier) // 2)
    if side < FOLDS or draws < 1 or samples < 1:
        raise ValueError(f"classifier floor: need at least {FOLDS} boards a half (one per "
                         f"fold), draws >= 1 and samples >= 1")
    return features(tier), mask, np.random.default_rng(seed)


def _split(mask: np.ndarray, split: str, rng: np.random.Generator) -> tuple[np.ndarray,
                                                                            np.ndarray]:
    """(calibration, held out) row indices of one draw."""
    if split == "spec":
        return np.flatnonzero(mask), np.flatnonzero(~mask)
    if split == "interleaved":
        return _interleaved_halves(len(mask), rng, True)
    order = rng.permutation(len(mask))
    held_out = int((~mask).sum())
    return np.sort(order[held_out:]), np.sort(order[:held_out])

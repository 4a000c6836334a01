"""Deterministic random streams, stable across numpy versions.

numpy does not promise that `Generator` methods keep their output across releases, but the raw
output of the PCG64 bit generator seeded by a `SeedSequence` is fixed. Every draw here is built
on that raw output, so a seed gives the same boards on any numpy >= 1.17.

Streams are disjoint per (family, variant, split, index): the spawn key of the SeedSequence.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypeVar

import numpy as np

from pcbdata.core.errors import UserError

T = TypeVar("T")

# Seeds travel in the manifest (JSON), in every parquet row (an int64 `seed` column) and into
# SeedSequence (non-negative integers only): 0 .. 2**63 - 1 is what all of them can hold.
MAX_SEED = 2**63 - 1

SPLIT_KEYS = {"train": 0, "validation": 1, "test": 2}
SEED_SCHEME = (
    "numpy SeedSequence(entropy=seed, spawn_key=(family, variant, split, index)) -> PCG64 raw "
    "64-bit outputs; family d1=1, d2=2; variant = grid size for d1, 0 for d2; split train=0, "
    "validation=1, test=2; floats = top 53 bits / 2**53; integers by rejection sampling"
)


def extended_scheme(keys: str, variants: str) -> str:
    """`SEED_SCHEME` naming more families: `keys` replaces "d1=1, d2=2" (e.g. "d1=1, d2=2,
    d2r=3") and `variants` replaces "0 for d2" (e.g. "0 for d2 and d2r")."""
    return SEED_SCHEME.replace("family d1=1, d2=2;", f"family {keys};").replace(
        "0 for d2;", f"{variants};")


def check_seed(seed, where: str = "seed") -> int:
    """`seed` if the whole pipeline can carry it, else UserError with the range."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise UserError(f"{where} must be an integer from 0 to 2**63 - 1 ({MAX_SEED}): seeds "
                        f"are stored as int64 in the published rows, got {seed!r}")
    return seed


class Stream:
    """One board's random stream."""

    def __init__(self, seed: int, family_key: int, variant: int, split: str, index: int):
        """`family_key`: the family's own key (`Family.seed_key`: d1 1, d2 2, d2r 3)."""
        sequence = np.random.SeedSequence(
            entropy=seed, spawn_key=(family_key, variant, SPLIT_KEYS[split], index)
        )
        self._bits = np.random.PCG64(sequence)

    def _raw(self) -> int:
        return int(self._bits.random_raw())

    def random(self) -> float:
        """Uniform float in [0, 1)."""
        return (self._raw() >> 11) * (1.0 / 9007199254740992.0)

    def uniform(self, low: float, high: float) -> float:
        return low + (high - low) * self.random()

    def integer(self, n: int) -> int:
        """Uniform integer in [0, n), without modulo bias."""
        if n <= 0:
            raise ValueError("integer(n) needs n >= 1")
        limit = (1 << 64) - ((1 << 64) % n)
        while True:
            value = self._raw()
            if value < limit:
                return value % n

    def choice(self, values: Sequence[T]) -> T:
        return values[self.integer(len(values))]

    def weighted(self, values: Sequence[T], weights: Sequence[float]) -> T:
        total = math.fsum(weights)
        target = self.random() * total
        acc = 0.0
        for value, weight in zip(values, weights):
            acc += weight
            if target < acc:
                return value
        return values[-1]

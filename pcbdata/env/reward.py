"""Phi (SPEC section 4) of the environment's board, through the evaluator's own pure metrics.

The one place where the environment meets `pcbdata.evaluator.metrics`: the counting rule
("strict": error-severity violations + unconnected items + the warnings via_dangling,
track_dangling, net_conflict; "evaluation": without those warnings) is the evaluator's.
"""
from __future__ import annotations

from pcbdata.evaluator import metrics
from pcbdata.evaluator.metrics import COUNTINGS, Weights, unconnected_from_clusters

__all__ = ["COUNTINGS", "EVALUATOR_COUNTING", "Telescope", "board_state", "canonical", "counted",
           "unconnected_from_clusters"]

#: The counting `pcbdata eval` reports Pot. under.
EVALUATOR_COUNTING = "strict"


def board_state(measurement: dict, weights: Weights, counting: str) -> dict:
    """The evaluator's `board_state` (DRV, U, f, WL, Via, Phi) under `counting`."""
    return metrics.board_state(measurement, weights, counting=counting)


def canonical(violations: list[dict]) -> list[dict]:
    """Violations in a canonical order: type, positions, nets (then severity, section)."""
    return sorted(violations, key=lambda v: (v["type"], [tuple(p) for p in v.get("positions", [])],
                                             list(v["nets"]), v["severity"], v["section"]))


class Telescope:
    """Per-step rewards whose running sum is exactly Phi(s_t) - Phi(s_0): each reward is the
    potential gain so far minus what was already paid out."""

    def __init__(self, phi0: float, per_step: bool):
        self.phi0 = phi0
        self.per_step = per_step
        self.paid = 0.0

    def reward(self, phi: float, final: bool) -> float:
        if not self.per_step and not final:
            return 0.0
        value = (phi - self.phi0) - self.paid
        self.paid += value
        return value


def counted(violations: list[dict], counting: str) -> list[dict]:
    """The violations `counting` counts (the same rule as `board_state`)."""
    return metrics.counted_violations(violations, counting=counting)

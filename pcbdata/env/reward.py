"""Phi (SPEC section 4) of the environment's board, through the evaluator's own pure metrics.

The one place where the environment meets `pcbdata.evaluator.metrics`: the counting rule
("strict": error-severity violations + unconnected items + the warnings via_dangling,
track_dangling, net_conflict; "evaluation": without those warnings) is applied here, through
the metrics' `counting` keyword when it has one, else by filtering first.
"""
from __future__ import annotations

import inspect

from pcbdata.evaluator import metrics
from pcbdata.evaluator.metrics import Weights

COUNTINGS = ("strict", "evaluation")


def _metrics_count() -> bool:
    return "counting" in inspect.signature(metrics.board_state).parameters


def evaluator_counting() -> str:
    """The counting `pcbdata eval` uses for Pot.: "evaluation" once the metrics take the
    `counting` keyword; before that, the evaluator counted the three warnings too ("strict")."""
    return "evaluation" if _metrics_count() else "strict"


def _evaluation_filter(violations: list[dict]) -> list[dict]:
    return [v for v in violations if v["severity"] != "excluded"
            and (v["section"] == "unconnected" or v["severity"] == "error")]


def board_state(measurement: dict, weights: Weights, counting: str) -> dict:
    """The evaluator's `board_state` (DRV, U, f, WL, Via, Phi) under `counting`."""
    if _metrics_count():
        return metrics.board_state(measurement, weights, counting=counting)
    if counting == "evaluation":
        measurement = {**measurement, "violations": _evaluation_filter(measurement["violations"])}
    return metrics.board_state(measurement, weights)


def canonical(violations: list[dict]) -> list[dict]:
    """Violations in a canonical order: type, positions, nets (then severity, section)."""
    return sorted(violations, key=lambda v: (v["type"], [tuple(p) for p in v.get("positions", [])],
                                             list(v["nets"]), v["severity"], v["section"]))


def unconnected_from_clusters(clusters: dict[str, int]) -> list[dict]:
    """Unconnected items as pad clusters give them (one per missing connection of a net), for
    steps without KiCad's DRC (option drc="terminal")."""
    return [{"type": "unconnected_items", "severity": "error", "section": "unconnected",
             "nets": [net], "no_net_item": False, "positions": []}
            for net, g in sorted(clusters.items()) for _ in range(max(0, g - 1))]


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
    if "counting" in inspect.signature(metrics.counted_violations).parameters:
        return metrics.counted_violations(violations, counting=counting)
    kept = metrics.counted_violations(violations)
    return _evaluation_filter(kept) if counting == "evaluation" else kept

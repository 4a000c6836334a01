"""The benchmark's metrics (SPEC section 4) as pure functions of the engine's measurements.

A measurement (see `pcbdata.kicad.scoring.measure`) is plain data: DRC violations as
`{type, severity, section, nets, no_net_item}`, pad-holding copper clusters per net, WL, vias,
KiCad's net count and an integrity fingerprint. Nothing here imports KiCad.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

#: Warning-severity DRC types that still count as violations.
COUNTED_WARNINGS = frozenset({"via_dangling", "track_dangling", "net_conflict"})
#: The shared bucket of counted violations that name no net.
NO_NET = "<no net>"


@dataclass(frozen=True)
class Weights:
    """The parameters of the potential: Phi = ln(1+N)[U=0] - U - f - lw WL - lv Via,
    f = net_weight ln(1 + X/2) + sum_i ln(1 + x_i/2)."""

    lw: float = 0.002  # per mm of track
    lv: float = 0.1  # per via
    net_weight: float = 3.0  # weight of the "how many nets are hit" term of f

    def as_dict(self) -> dict:
        return asdict(self)


DEFAULT_WEIGHTS = Weights()


def is_counted(violation: dict) -> bool:
    """Counted violation: severity `error` as the project resolves it, or one of the warning
    types of `COUNTED_WARNINGS`, or any unconnected item; excluded ones never count."""
    severity = violation["severity"]
    if severity == "excluded":
        return False
    if violation["section"] == "unconnected":
        return True
    if severity == "error":
        return True
    return severity == "warning" and violation["type"] in COUNTED_WARNINGS


def counted_violations(violations: list[dict]) -> list[dict]:
    return [v for v in violations if is_counted(v)]


def unconnected_count(violations: list[dict]) -> int:
    """U(s): the number of unconnected items (open ratsnest edges); excluded ones don't count."""
    return sum(1 for v in violations if v["section"] == "unconnected" and v["severity"] != "excluded")


def violations_per_net(counted: list[dict]) -> dict[str, int]:
    """x_i: counted violations touching net i. A violation naming two nets counts for both; one
    naming no net counts once for the shared `NO_NET` bucket."""
    per_net: dict[str, int] = {}
    for violation in counted:
        nets = violation.get("nets") or [NO_NET]
        for net in sorted(set(nets)):
            per_net[net] = per_net.get(net, 0) + 1
    return per_net


def drc_penalty(counted: list[dict], weights: Weights = DEFAULT_WEIGHTS) -> float:
    """f(s) = 3 ln(1 + X/2) + sum_i ln(1 + x_i/2); X = number of buckets (nets) with x_i > 0."""
    per_net = violations_per_net(counted)
    hit = sum(1 for x in per_net.values() if x > 0)
    return weights.net_weight * math.log1p(hit / 2) + sum(math.log1p(x / 2) for x in per_net.values())


def routability(clusters_bare: dict[str, int], clusters_routed: dict[str, int]) -> float:
    """sum_nets (G0 - Gt) / sum_nets (G0 - 1), G = pad-holding copper clusters of a net; G0 from
    the bare board. 1.0 when nothing needs connecting. A net missing from the routed board
    counts as unrouted (Gt = G0)."""
    need = sum(g0 - 1 for g0 in clusters_bare.values() if g0 > 1)
    if need == 0:
        return 1.0
    done = sum(g0 - clusters_routed.get(net, g0) for net, g0 in clusters_bare.items() if g0 > 1)
    return done / need


def potential(net_count: int, unconnected: int, penalty: float, wl_mm: float, vias: int,
              weights: Weights = DEFAULT_WEIGHTS) -> float:
    """Phi(s) = ln(1 + N) [U(s) = 0] - U(s) - f(s) - lw WL(s) - lv Via(s)."""
    bonus = math.log1p(net_count) if unconnected == 0 else 0.0
    return bonus - unconnected - penalty - weights.lw * wl_mm - weights.lv * vias


def board_state(measurement: dict, weights: Weights = DEFAULT_WEIGHTS) -> dict:
    """DRV, U, f, WL, Via and Phi of one measured board."""
    counted = counted_violations(measurement["violations"])
    unconnected = unconnected_count(measurement["violations"])
    penalty = drc_penalty(counted, weights)
    counts: dict[str, int] = {}
    for violation in counted:
        counts[violation["type"]] = counts.get(violation["type"], 0) + 1
    return {
        "drv": len(counted),
        "unconnected": unconnected,
        "penalty": penalty,
        "wl": measurement["wl_mm"],
        "via": measurement["vias"],
        "net_count": measurement["net_count"],
        "phi": potential(measurement["net_count"], unconnected, penalty, measurement["wl_mm"],
                         measurement["vias"], weights),
        "drv_by_type": dict(sorted(counts.items())),
    }


def rollout_metrics(bare: dict, routed: dict, weights: Weights = DEFAULT_WEIGHTS) -> dict:
    """The scores of one routed board against its bare instance (both measurements)."""
    state = board_state(routed, weights)
    phi_bare = board_state(bare, weights)["phi"]
    rout = routability(bare["clusters"], routed["clusters"])
    return {
        "cp": int(rout == 1.0 and state["drv"] == 0),
        "pot": state["phi"] - phi_bare,
        "rout": rout,
        "drv": state["drv"],
        "unconnected": state["unconnected"],
        "wl": state["wl"],
        "via": state["via"],
        "penalty": state["penalty"],
        "phi": state["phi"],
        "phi_bare": phi_bare,
        "net_count": state["net_count"],
        "drv_by_type": state["drv_by_type"],
    }


def selection_key(record: dict) -> tuple:
    """Sort key of the @k protocol: the smallest key wins. Largest Pot., then higher routability,
    fewer DRV, shorter WL, fewer vias, lower rollout index."""
    return (-record["pot"], -record["rout"], record["drv"], record["wl"], record["via"],
            record["index"])


def pick_best(records: list[dict]) -> dict | None:
    """The rollout kept for a board among its scored ones (status `ok`), or None."""
    scored = [r for r in records if r["status"] == "ok"]
    return min(scored, key=selection_key) if scored else None

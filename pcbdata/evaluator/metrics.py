"""The benchmark's metrics (SPEC section 4) as pure functions of the engine's measurements.

A measurement (see `pcbdata.kicad.scoring.measure`) is plain data: DRC violations as
`{type, severity, section, nets, no_net_item, ...}`, pad-holding copper clusters per net, WL,
vias, KiCad's net count and an integrity fingerprint. Nothing here imports KiCad. Every
violation count takes `counting` ("evaluation" or "strict", see `COUNTINGS`); sums are exact
(`math.fsum`) and per-net buckets sorted, so a result does not depend on the order of the
violations.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import asdict, dataclass

from pcbdata.kicad.drc_report import UNCONNECTED_LIST_CAP

#: The two ways of counting DRC violations (SPEC 4). "evaluation": error-severity violations
#: (as the project resolves them) and every unconnected item; DRV and CP (the published
#: Reference rows keep CP 1.00, DRV 0.00 only with it). "strict": the same plus the warnings of
#: `STRICT_WARNINGS`; f, Phi and Pot. (the published Reference Pot. is reproduced only with
#: it), the report's DRV+ and CP+, and the routing environment's default reward.
COUNTINGS = ("evaluation", "strict")
#: Warning types the strict count adds.
STRICT_WARNINGS = frozenset({"via_dangling", "track_dangling", "net_conflict"})
COUNTED_WARNINGS = STRICT_WARNINGS  # the name bench/bench_eval.py imports
#: The shared bucket of counted violations that name no net.
NO_NET = "<no net>"


@dataclass(frozen=True)
class Weights:
    """The parameters of the potential: Phi = ln(1+N)[U=0] - U - f - lw WL - lv Via,
    f = net_weight ln(1 + X/2) + sum_i ln(1 + x_i/2)."""

    lw: float = 0.002  # per mm of track
    lv: float = 0.1  # per via
    net_weight: float = 3.0  # weight of the "how many nets are hit" term of f
    #: whether Phi of the bare board counts its DRC term f (SPEC 4: it does; the published D1
    #: convention takes Phi(bare) = -U0). Only the evaluator's Pot. reads it.
    bare_drc: bool = True

    def as_dict(self) -> dict:
        return asdict(self)


DEFAULT_WEIGHTS = Weights()
#: Named scoring conventions (SPEC 4): "spec", the formula as defined (the default), and
#: "d1-published", the paper's D1 Pot. column: lw = lv = 0 and Phi(bare) = -U0, so a clean,
#: complete D1 route scores ln 7 + 5 = 6.946 and an untouched board -5.786.
CONVENTIONS = {"spec": DEFAULT_WEIGHTS,
               "d1-published": Weights(lw=0.0, lv=0.0, bare_drc=False)}


def convention_of(weights: Weights) -> str:
    """The name of the convention `weights` are, or "custom"."""
    return next((name for name, w in CONVENTIONS.items() if w == weights), "custom")


def _check_counting(counting: str) -> None:
    if counting not in COUNTINGS:
        raise ValueError(f"counting must be one of {', '.join(COUNTINGS)}, not {counting!r}")


def is_counted(violation: dict, counting: str = "evaluation") -> bool:
    """Whether `counting` counts a violation: any unconnected item, severity `error` as the
    project resolves it, and (strict only) the warnings of `STRICT_WARNINGS`; excluded ones
    never count."""
    _check_counting(counting)
    severity = violation["severity"]
    if severity == "excluded":
        return False
    if violation["section"] == "unconnected" or severity == "error":
        return True
    return counting == "strict" and severity == "warning" and violation["type"] in STRICT_WARNINGS


def counted_violations(violations: list[dict], counting: str = "evaluation") -> list[dict]:
    return [v for v in violations if is_counted(v, counting)]


def unconnected_count(violations: list[dict]) -> int:
    """U(s): the number of unconnected items (open ratsnest edges); excluded ones don't count."""
    return sum(1 for v in violations
               if v["section"] == "unconnected" and v["severity"] != "excluded")


def violations_per_net(counted: list[dict]) -> dict[str, int]:
    """x_i: counted violations touching net i, sorted by net. A violation naming two nets
    counts for both; one naming no net counts once for the shared `NO_NET` bucket."""
    per_net: dict[str, int] = {}
    for violation in counted:
        nets = violation.get("nets") or [NO_NET]
        for net in set(nets):
            per_net[net] = per_net.get(net, 0) + 1
    return dict(sorted(per_net.items()))


def drc_penalty(counted: list[dict], weights: Weights = DEFAULT_WEIGHTS) -> float:
    """f(s) = 3 ln(1 + X/2) + sum_i ln(1 + x_i/2); X = number of buckets (nets) with x_i > 0."""
    return penalty_of(violations_per_net(counted), weights)


def penalty_of(per_net: dict[str, int], weights: Weights = DEFAULT_WEIGHTS) -> float:
    """f from the counted violations per net (`violations_per_net`). Summed exactly (fsum over
    the nets in sorted order): the order in which KiCad reported the violations cannot change
    the last digit."""
    per_net = dict(sorted(per_net.items()))
    hit = sum(1 for x in per_net.values() if x > 0)
    return math.fsum([weights.net_weight * math.log1p(hit / 2),
                      *(math.log1p(x / 2) for x in per_net.values())])


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
    return math.fsum([bonus, -unconnected, -penalty, -weights.lw * wl_mm, -weights.lv * vias])


def unconnected_from_clusters(clusters: dict[str, int]) -> list[dict]:
    """Unconnected items as pad clusters give them: one per missing connection of a net
    (G - 1 for a net whose pads sit on G copper clusters; SPEC 4's U summed over nets)."""
    return [{"type": "unconnected_items", "severity": "error", "section": "unconnected",
             "nets": [net], "no_net_item": False, "positions": []}
            for net, g in sorted(clusters.items()) for _ in range(max(0, g - 1))]


def every_unconnected(measurement: dict) -> list[dict]:
    """The measurement's violations with every unconnected item. KiCad's DRC lists at most
    `UNCONNECTED_LIST_CAP` of them, so a list that long is replaced by the pad clusters'
    items (a board with 1,616 missing connections would otherwise count U = 499, and routing
    its first thousand would gain nothing). Shorter lists are KiCad's, as they are."""
    violations = measurement["violations"]
    listed = sum(1 for v in violations if v["section"] == "unconnected")
    if listed < UNCONNECTED_LIST_CAP or "clusters" not in measurement:
        return violations
    return ([v for v in violations if v["section"] != "unconnected"]
            + unconnected_from_clusters(measurement["clusters"]))


def board_state(measurement: dict, weights: Weights = DEFAULT_WEIGHTS,
                counting: str = "strict") -> dict:
    """DRV, U, f, WL, Via and Phi of one measured board under `counting` (see `COUNTINGS`).
    Needs `violations`, `wl_mm`, `vias` and `net_count` of the measurement, and `clusters`
    when KiCad's list of unconnected items is full (`every_unconnected`)."""
    violations = every_unconnected(measurement)
    counted = counted_violations(violations, counting)
    unconnected = unconnected_count(violations)
    penalty = drc_penalty(counted, weights)
    return {
        "drv": len(counted),
        "unconnected": unconnected,
        "penalty": penalty,
        "wl": measurement["wl_mm"],
        "via": measurement["vias"],
        "net_count": measurement["net_count"],
        "phi": potential(measurement["net_count"], unconnected, penalty, measurement["wl_mm"],
                         measurement["vias"], weights),
        "drv_by_type": dict(sorted(Counter(v["type"] for v in counted).items())),
    }


def board_counts(measurement: dict) -> dict:
    """The raw counts of one measured board that every figure derives from: U, WL, Via, N and,
    per counting, the counted violations per net (f) and per type (DRV)."""
    violations = every_unconnected(measurement)
    counts: dict = {"unconnected": unconnected_count(violations), "wl": measurement["wl_mm"],
                    "via": measurement["vias"], "net_count": measurement["net_count"]}
    for counting in COUNTINGS:
        counted = counted_violations(violations, counting)
        counts[counting] = {"per_net": violations_per_net(counted),
                            "by_type": dict(sorted(Counter(v["type"] for v in counted).items()))}
    return counts


def raw_counts(bare: dict, routed: dict) -> dict:
    """What a rollout's scores are computed from (`rollout_metrics`): the raw counts of the
    routed board and of its bare instance, and routability's numerator and denominator. The
    evaluator caches these, never the derived figures."""
    need = sum(g0 - 1 for g0 in bare["clusters"].values() if g0 > 1)
    done = sum(g0 - routed["clusters"].get(net, g0)
               for net, g0 in bare["clusters"].items() if g0 > 1)
    return {"routed": board_counts(routed), "bare": board_counts(bare),
            "rout_done": done, "rout_need": need}


def _phi(counts: dict, counting: str, weights: Weights) -> tuple[float, float]:
    """(f, Phi) of a board's raw counts under `counting`."""
    penalty = penalty_of(counts[counting]["per_net"], weights)
    phi = potential(counts["net_count"], counts["unconnected"], penalty, counts["wl"],
                    counts["via"], weights)
    return penalty, phi


#: The suffix of each counting's Pot., f and Phi in a record: Pot. is the strict count's.
POT_SUFFIX = {"strict": "", "evaluation": "_evaluation"}


def rollout_metrics(raw: dict, weights: Weights = DEFAULT_WEIGHTS) -> dict:
    """The scores of one rollout from its raw counts (`raw_counts`). CP and DRV use the
    evaluation count, CP+ (`cp_strict`) and DRV+ (`drv_strict`) the strict one; f (`penalty`),
    Phi (`phi`, `phi_bare`) and Pot. (`pot`) the strict count, with the evaluation count's
    reading beside them as diagnostics (`pot_evaluation`, `penalty_evaluation`, ...)."""
    routed, bare = raw["routed"], raw["bare"]
    rout = raw["rout_done"] / raw["rout_need"] if raw["rout_need"] else 1.0
    record: dict = {"rout": rout, "unconnected": routed["unconnected"], "wl": routed["wl"],
                    "via": routed["via"], "net_count": routed["net_count"]}
    for counting, suffix in (("evaluation", ""), ("strict", "_strict")):
        by_type = routed[counting]["by_type"]
        drv = sum(by_type.values())
        record.update({f"cp{suffix}": int(rout == 1.0 and drv == 0), f"drv{suffix}": drv,
                       f"drv{suffix}_by_type": dict(by_type)})
    for counting, suffix in POT_SUFFIX.items():
        penalty, phi = _phi(routed, counting, weights)
        phi_bare = _phi(bare, counting, weights)[1] if weights.bare_drc else -bare["unconnected"]
        record.update({f"pot{suffix}": phi - phi_bare, f"penalty{suffix}": penalty,
                       f"phi{suffix}": phi, f"phi_bare{suffix}": phi_bare})
    return dict(sorted(record.items()))


def selection_key(record: dict) -> tuple:
    """Sort key of the @k protocol: the smallest key wins. Largest Pot. (strict count), then
    higher routability, fewer DRV, shorter WL, fewer vias, lower rollout index."""
    return (-record["pot"], -record["rout"], record["drv"], record["wl"], record["via"],
            record["index"])


def pick_best(records: list[dict]) -> dict | None:
    """The rollout kept for a board among its scored ones (status `ok`), or None."""
    scored = [r for r in records if r["status"] == "ok"]
    return min(scored, key=selection_key) if scored else None

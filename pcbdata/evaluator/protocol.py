"""The @k protocol of SPEC 4 on scored rollouts: a board's kept rollout and its figures
(`board_row`), and a set's figures (`summarize`). Pure data, no files: `pcbdata eval`'s
reports and `results.json` both derive their figures here."""
from __future__ import annotations

import math

from pcbdata.evaluator.metrics import pick_best

#: What a board row takes from its kept rollout (the @k choice picks by Pot., strict count).
BEST_FIELDS = ("cp", "pot", "rout", "drv", "unconnected", "wl", "via", "cp_strict", "drv_strict",
               "pot_evaluation")
#: A board with no scored rollout is the bare board in the set's figures (SPEC 4): nothing
#: routed, nothing gained. WL, Via and DRV have no value for it.
NO_SCORED_ROLLOUT = {"cp": 0, "cp_strict": 0, "rout": 0.0, "pot": 0.0, "pot_evaluation": 0.0}


def _mean(values: list) -> float | None:
    """Mean of the known values, summed exactly so that the order of the rows cannot change it."""
    values = [v for v in values if v is not None]
    return math.fsum(values) / len(values) if values else None


def board_row(board_id: str, records: list[dict]) -> dict:
    """The @k result of one board from its rollout records."""
    best = pick_best(records)
    n_parse = sum(r["status"] == "parse_fail" for r in records)
    row = {"board_id": board_id, "n_rollouts": len(records),
           "n_ok": sum(r["status"] == "ok" for r in records),
           "n_invalid": sum(r["status"] == "invalid" for r in records),
           "n_parse_fail": n_parse, "parse_fail": int(n_parse == len(records)),
           "time": _mean([r.get("time") for r in records])}
    if best is None:
        row.update({key: None for key in BEST_FIELDS}, best_rollout=None, **NO_SCORED_ROLLOUT)
    else:
        row.update({key: best.get(key) for key in BEST_FIELDS}, best_rollout=best["rollout"])
    return row


def summarize(board_rows: list[dict], rollouts: list[dict], k: int) -> dict:
    """The per-set summary. CP, Rout. and Pot. average over all boards (a board with no scored
    rollout counts as its bare board: `NO_SCORED_ROLLOUT`); DRV, WL and Via over boards with a
    scored rollout (`n_boards_scored`); Time over the rollouts that report one (`n_timed`);
    parse_fail over boards, parse_fail_at1 and invalid over rollouts."""
    n = len(board_rows)
    n_roll = len(rollouts)
    return {
        "n_boards": n,
        "k": k,
        "cp": _mean([r["cp"] for r in board_rows]),
        "cp_strict": _mean([r["cp_strict"] for r in board_rows]),
        "pot": _mean([r["pot"] for r in board_rows]),
        "pot_evaluation": _mean([r["pot_evaluation"] for r in board_rows]),
        "rout": _mean([r["rout"] for r in board_rows]),
        "drv": _mean([r["drv"] for r in board_rows]),
        "drv_strict": _mean([r.get("drv_strict") for r in board_rows]),
        "wl": _mean([r["wl"] for r in board_rows]),
        "via": _mean([r["via"] for r in board_rows]),
        "time": _mean([r.get("time") for r in rollouts]),
        "n_timed": sum(r.get("time") is not None for r in rollouts),
        "parse_fail": (sum(r["parse_fail"] for r in board_rows) / n) if n else None,
        "parse_fail_at1": ((sum(r["status"] == "parse_fail" for r in rollouts) / n_roll)
                           if n_roll else None),
        "invalid": (sum(r["status"] == "invalid" for r in rollouts) / n_roll) if n_roll else None,
        "n_rollouts": n_roll,
        "n_invalid": sum(r["status"] == "invalid" for r in rollouts),
        "n_parse_fail_rollouts": sum(r["status"] == "parse_fail" for r in rollouts),
        "n_boards_scored": sum(r["best_rollout"] is not None for r in board_rows),
    }

"""Language-model accounting of a submission, summed for `pcbdata eval`'s summary.json (`llm`).

A rollout of a language-model agent (`pcbdata rollout --agent llm | llm-plan | llm-direct`)
records `llm.accounting` in its `<rollout>.json`: requests, retries, prompt and completion
tokens as the server reported them, latency, parse failures. The totals are the sums of
those numbers over the scored rollouts that have them; a submission without any has none.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from pathlib import Path


def _number(value) -> bool:
    return (isinstance(value, int | float) and not isinstance(value, bool)
            and math.isfinite(value))


def llm_totals(board_files: Iterable[Path],
               read: Callable[[Path], tuple[object, str]]) -> dict | None:
    """Sums of the numeric `llm.accounting` fields of the rollouts' sidecars (read with
    `read`, which gives (data, problem)); `rollouts` counts the sidecars that had them. None
    when no sidecar has any (unreadable sidecars are left out: eval reports them already)."""
    totals: dict[str, float] = {}
    rollouts = 0
    for board in board_files:
        sidecar = board.with_suffix(".json")
        if not sidecar.is_file():
            continue
        data, problem = read(sidecar)
        llm = data.get("llm") if isinstance(data, dict) and not problem else None
        accounting = llm.get("accounting") if isinstance(llm, dict) else None
        if not isinstance(accounting, dict):
            continue
        rollouts += 1
        for key, value in accounting.items():
            if _number(value):
                totals[key] = totals.get(key, 0) + value
    if not rollouts:
        return None
    rounded = {k: round(v, 6) if isinstance(v, float) else v for k, v in sorted(totals.items())}
    return {"rollouts": rollouts, **rounded}

"""The environment's keyword options: defaults, capacities per family, and checking (an
unknown option is an error naming the closest known one)."""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, fields, replace
from typing import Any

from pcbdata.env.errors import EnvOptionError, EnvValueError
from pcbdata.evaluator.metrics import Weights
from pcbdata.generators.families import CURATED
from pcbdata.generators.families import family as family_record
from pcbdata.router.walkaround import BUDGET_CHECKS, BUDGET_NODES

#: Fixed array sizes of the observation (per family: `Family.capacities`, D3's below); a board
#: larger than these is a clear error at reset naming the option to raise.
D3_CAPACITIES = {"max_nets": 1024, "max_pads": 4096, "max_tracks": 4096, "max_vias": 1024,
                 "max_outline_points": 2048, "max_ratsnest": 2048}
CAPACITY_NAMES = tuple(D3_CAPACITIES)


def capacities(family: str) -> dict[str, int]:
    """The observation's array sizes for a family's boards (its `Family.capacities`; D3's
    here)."""
    if family == CURATED:
        return dict(D3_CAPACITIES)
    return dict(family_record(family).capacities)


@dataclass(frozen=True)
class EnvOptions:
    config: str = "d2"
    root: str | None = None  # a built set folder; None: D1/D2 boards from the generator
    split: str = "test"
    rows: object = None  # dataset rows (e.g. `load_dataset(...)`): boards written to files
    count: int | None = None  # boards of the split to draw from (default: all)
    max_steps: int | None = None  # None: max(200, 8 * connections left at reset), per board
    reward: str = "dense"  # "dense": r_t = Phi(s_t+1) - Phi(s_t); "terminal": at the end only
    counting: str = "strict"  # "strict" or "evaluation" (SPEC section 4)
    weights: Weights = Weights()
    drc: str = "step"  # "step": KiCad DRC after every copper change; "terminal": at the end
    ring_mm: float = 0.5
    max_candidates: int = 64
    max_nets: int = 0  # 0: the family's capacity (`capacities`)
    max_pads: int = 0
    max_tracks: int = 0
    max_vias: int = 0
    max_outline_points: int = 0
    max_ratsnest: int = 0
    max_violations: int = 32
    router_nodes: int = BUDGET_NODES  # walkaround search budget: expansions ...
    router_checks: int = BUDGET_CHECKS  # ... and link checks (machine-independent counts)
    router_seconds: float | None = None  # a wall-clock limit too; runs then are not reproducible
    finish_tries: int = 3
    finish: bool = True  # False: the finish action is masked in every phase (never offered)
    cleanup: bool = True  # net_end and push_n_shove delete their nets' dangling tracks and vias
    task_timeout: float = 120.0
    engine_env: dict | None = None  # environment of the KiCad worker (e.g. LD_PRELOAD)
    fast_drc: bool = True  # False: the worker runs without pcbdata.kicad.fastwait's preload
    render_mode: str | None = None


CHOICES = {"reward": ("dense", "terminal"), "counting": ("strict", "evaluation"),
           "drc": ("step", "terminal"), "split": ("train", "validation", "test", "full")}
#: Old spellings still read: reward="step" is the dense reward's earlier name.
ALIASES = {"reward": {"step": "dense"}}


def make_options(**given) -> EnvOptions:
    """EnvOptions from keywords; unknown names and bad choices raise with the closest name.
    Capacities left at 0 stay 0 here: `with_capacities` fills them once the config's family is
    known (from the set's manifest or the registry, not from the config's name)."""
    known = [f.name for f in fields(EnvOptions)]
    for name in given:
        if name not in known:
            close = difflib.get_close_matches(name, known, n=1, cutoff=0.5)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise EnvOptionError(f"unknown option {name!r} for the pcbdata routing "
                                 f"environment{hint} (options: {', '.join(known)})")
    for name, spellings in ALIASES.items():
        if isinstance(given.get(name), str) and given[name] in spellings:
            given[name] = spellings[given[name]]
    if isinstance(given.get("weights"), dict):
        given["weights"] = Weights(**given["weights"])
    options = EnvOptions(**given)
    for name, allowed in CHOICES.items():
        value = getattr(options, name)
        if value not in allowed:
            close = difflib.get_close_matches(str(value), allowed, n=1, cutoff=0.3)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise EnvValueError(f"option {name}={value!r} is not one of {', '.join(allowed)}{hint}")
    negative = [name for name in CAPACITY_NAMES if getattr(options, name) < 0]
    if negative:
        raise EnvValueError(f"{negative[0]} must be >= 1 (0: the family's default)")
    if (options.max_steps is not None and options.max_steps < 1) or options.max_candidates < 9:
        raise EnvValueError("max_steps must be >= 1 and max_candidates >= 9 (8 ring slots + 1)")
    _check_router_budget(options)
    return options


def with_capacities(options: EnvOptions, family: str) -> EnvOptions:
    """`options` with every capacity left at 0 set to the family's (`capacities`)."""
    caps = capacities(family)
    unset: dict[str, Any] = {k: v for k, v in caps.items() if getattr(options, k) == 0}
    return replace(options, **unset)


def _check_router_budget(options: EnvOptions) -> None:
    for name in ("router_nodes", "router_checks"):
        value = getattr(options, name)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise EnvValueError(f"{name} must be a whole number >= 0, not {value!r}")
    seconds = options.router_seconds
    if seconds is not None and (isinstance(seconds, bool) or not isinstance(seconds, int | float)
                                or not math.isfinite(seconds) or seconds <= 0):
        raise EnvValueError(f"router_seconds must be None or a number of seconds > 0, "
                            f"not {seconds!r}")

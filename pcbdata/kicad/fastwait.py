"""The preload that removes KiCad's 250 ms DRC polling sleep from worker processes.

KiCad 9.0.8's DRC waits for its track-clearance threads by sleeping 250 ms at a time, so
every DRC of a board with tracks takes at least 250 ms however small the board is.
`fastwait/fastwait.c`, preloaded into a worker, turns long sleeps made by KiCad's own code into
1 ms ones; the loop re-checks its condition, so results are unchanged (see DEVELOPERS.md,
"KiCad's DRC polling wait"). `scripts/build-fastwait.sh` builds it; without it workers run as
before. `PCBDATA_FAST_DRC=0` turns it off.

The loader reads LD_PRELOAD only when a process starts, so the variables from `preload_env`
must be in the environment the worker is started with (exec time), not set inside it.
"""
from __future__ import annotations

import json
import os
import re
import time
from pathlib import Path

LIBRARY_NAME = "libpcbdata_fastwait.so"
SWITCH = "PCBDATA_FAST_DRC"
_BUILT = Path(__file__).resolve().parents[2] / "build" / "fastwait" / LIBRARY_NAME


def library_path() -> str | None:
    """The built preload library, or None when it has not been built (no C compiler, or an
    install without the source tree)."""
    return str(_BUILT) if _BUILT.is_file() else None


def enabled_by_environment() -> bool:
    """False when the user turned the fix off with PCBDATA_FAST_DRC=0 (or false/no/off)."""
    return os.environ.get(SWITCH, "1").strip().lower() not in {"0", "false", "no", "off"}


def _preloads(value: str) -> list[str]:
    # ld.so accepts spaces and colons as separators.
    return value.replace(":", " ").split()


def preload_env(enabled: bool = True) -> dict[str, str]:
    """The LD_PRELOAD a KiCad worker starts with: the library added (kept first, so it sees
    nanosleep before any other preload) or, when turned off, removed; other preloads already
    in the environment are kept. Always the whole value, so that a pool given
    `preload_env(False)` really starts its workers without it."""
    current = _preloads(os.environ.get("LD_PRELOAD", ""))
    others = [entry for entry in current if os.path.basename(entry) != LIBRARY_NAME]
    library = library_path() if enabled and enabled_by_environment() else None
    if library is not None and any(sep in library for sep in " :"):
        library = None  # ld.so would split the path: run without rather than misload
    return {"LD_PRELOAD": " ".join(([library] if library else []) + others)}


def shortened_sleeps() -> int | None:
    """In a worker: how many KiCad sleeps the preload has cut short so far; None when the
    library is not loaded in this process."""
    import ctypes

    try:
        counter = ctypes.CDLL(None).pcbdata_fastwait_shortened
    except AttributeError:
        return None
    counter.restype = ctypes.c_ulong
    return int(counter())


def timed_drc(path: str, project: str | None = None, custom_rules: str | None = None) -> dict:
    """Worker task: `basics.drc` plus its wall time and what the preload did meanwhile."""
    from pcbdata.kicad.basics import drc

    before = shortened_sleeps()
    start = time.perf_counter()
    report = drc(path, project, custom_rules)
    seconds = time.perf_counter() - start
    after = shortened_sleeps()
    shortened = after - before if after is not None and before is not None else 0
    return {"report": report, "seconds": seconds, "preloaded": after is not None,
            "shortened": shortened}


_NET_PAIR = re.compile(r"\(nets (.*) and (.*)\)$")


def canonical_violations(report: dict) -> list[str]:
    """A DRC report's violations in a form that does not depend on thread timing, sorted.

    KiCad checks item pairs on several threads, and which item of a pair comes first (in the
    item list and in "Items shorting two nets (nets A and B)") changes from run to run, with or
    without the preload. Everything else (type, rule, severity, items, positions) must match."""
    out = []
    for violation in report["violations"]:
        message = violation["message"]
        pair = _NET_PAIR.search(message)
        if pair:
            first, second = sorted(pair.groups())
            message = message[:pair.start()] + f"(nets {first} and {second})"
        items = sorted(json.dumps(item, sort_keys=True) for item in violation["items"])
        out.append(json.dumps({**violation, "message": message, "items": items}, sort_keys=True))
    return sorted(out)

"""What machine a figure was measured on: cores, CPU model and load, as plain data.

Rollouts record it in their JSON (their times depend on it) and `pcbdata eval` in
`results.json` (the machine that scored them). Anything the system does not tell is None.
"""
from __future__ import annotations

import os
from pathlib import Path

CPUINFO = Path("/proc/cpuinfo")


def cpu_model() -> str | None:
    """The CPU's model name as Linux reports it (`/proc/cpuinfo`), or None."""
    try:
        text = CPUINFO.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() in ("model name", "Model", "cpu model") and value.strip():
            return value.strip()
    return None


def load_average() -> list[float] | None:
    """The 1, 5 and 15 minute load averages, or None where the system has none."""
    try:
        return [round(value, 2) for value in os.getloadavg()]
    except OSError:
        return None


def machine_info() -> dict:
    """{"cores", "cpu_model", "load"} of this machine now (None where unknown)."""
    return {"cores": os.cpu_count(), "cpu_model": cpu_model(), "load": load_average()}

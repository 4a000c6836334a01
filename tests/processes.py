"""Finding the processes a test started, by a marker in their environment (workers inherit
it), to check that none outlives its run."""
from __future__ import annotations

import os
import time
import uuid
from pathlib import Path


def new_marker() -> str:
    return f"pcbdata-test-{uuid.uuid4().hex}"


def marked_env(marker: str, **extra: str) -> dict[str, str]:
    repo = str(Path(__file__).resolve().parents[1])
    path = os.pathsep.join(p for p in (repo, os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PCBDATA_TEST_MARKER": marker, "PYTHONPATH": path, **extra}


def marked_processes(marker: str) -> dict[int, str]:
    """pid -> command line of every live process whose environment holds `marker`."""
    found = {}
    needle = f"PCBDATA_TEST_MARKER={marker}".encode()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if needle in (entry / "environ").read_bytes():
                cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ")
                found[int(entry.name)] = cmdline.decode(errors="replace")
        except OSError:  # gone, or not ours
            continue
    return found


def running(pids: list[int]) -> list[int]:
    """The pids among `pids` of processes still running: a zombie (dead, waiting for its parent,
    e.g. Ray's raylet on a loaded machine, to reap it) holds nothing and does not count."""
    out = []
    for pid in pids:
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except OSError:  # gone
            continue
        if stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X"):
            out.append(pid)
    return out


def wait_for(condition, seconds: float, step: float = 0.1):
    """Polls `condition()` until it returns something truthy or `seconds` pass; returns it."""
    deadline = time.monotonic() + seconds
    while True:
        value = condition()
        if value or time.monotonic() >= deadline:
            return value
        time.sleep(step)

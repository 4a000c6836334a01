"""No process outlives its run: a build killed early (SIGKILL or SIGTERM) leaves no worker and
no multiprocessing helper (resource tracker) behind."""
from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.processes import marked_env, marked_processes, new_marker, wait_for

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("delay, sig", [(0.3, signal.SIGKILL), (2.0, signal.SIGTERM),
                                        (2.0, signal.SIGKILL)])
def test_a_killed_build_leaves_no_process(tmp_path, delay, sig):
    marker = new_marker()
    build = subprocess.Popen([sys.executable, "-m", "pcbdata", "build", "d2", "--splits", "test",
                              "--workers", "2", "--out", str(tmp_path / "set")], cwd=REPO,
                             env=marked_env(marker), stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    seen: dict[int, str] = {}
    try:
        end = time.monotonic() + delay
        while time.monotonic() < end:
            seen.update(marked_processes(marker))
            time.sleep(0.05)
        build.send_signal(sig)
        build.wait(10)
        assert wait_for(lambda: not marked_processes(marker), 5), marked_processes(marker)
    finally:
        build.kill()
        build.wait()
    assert not [c for c in seen.values() if "multiprocessing" in c], seen

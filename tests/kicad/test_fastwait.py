"""The DRC-wait preload (`pcbdata.kicad.fastwait`): same violations with and without it, on
real KiCad, and nothing but KiCad's own long sleeps is touched.

The full 128-board D2 parity, freeroute-routed boards and the timings are in
`bench/bench_drc_wait.py`; here a sample keeps the test short.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import time

import pytest

from pcbdata.kicad import fastwait
from pcbdata.testing.drc import drc_parity, with_straight_tracks
from pcbdata.testing.sets import write_board
from tests.conftest import SHARED_PCBENCH
from tests.helpers import skip_without_snapshot

D2_SAMPLE = range(0, 128, 4)  # 32 of the 128 D2 test boards
D3_SAMPLE = 6  # the smallest real boards of the snapshot with at least MIN_TRACKS tracks
# KiCad sleeps only when its thread pool is still busy at its first poll: on boards of 6-30
# tracks it often is not, and no sleep was cut on any of 6 such boards in one run of three.
MIN_TRACKS = 200

needs_library = pytest.mark.skipif(
    fastwait.library_path() is None,
    reason="the preload is not built: run scripts/build-fastwait.sh (needs gcc)")


def test_preload_env_adds_keeps_and_removes_the_library(monkeypatch):
    library = "/x/build/fastwait/libpcbdata_fastwait.so"
    monkeypatch.setattr(fastwait, "library_path", lambda: library)
    monkeypatch.setenv("LD_PRELOAD", "/other/libfoo.so")
    monkeypatch.delenv(fastwait.SWITCH, raising=False)
    ours = "/x/build/fastwait/libpcbdata_fastwait.so /other/libfoo.so"
    assert fastwait.preload_env() == {"LD_PRELOAD": ours}
    assert fastwait.preload_env(enabled=False) == {"LD_PRELOAD": "/other/libfoo.so"}
    monkeypatch.setenv(fastwait.SWITCH, "0")
    assert fastwait.preload_env() == {"LD_PRELOAD": "/other/libfoo.so"}
    monkeypatch.setenv("LD_PRELOAD", ours)  # inherited from a parent: turning off removes it
    assert fastwait.preload_env() == {"LD_PRELOAD": "/other/libfoo.so"}


def test_no_library_no_preload(monkeypatch):
    monkeypatch.setattr(fastwait, "library_path", lambda: None)
    monkeypatch.delenv("LD_PRELOAD", raising=False)
    assert fastwait.preload_env() == {"LD_PRELOAD": ""}


@needs_library
def test_sleeps_outside_kicad_keep_their_length():
    # Python's time.sleep and a plain libc nanosleep called through ctypes are not KiCad's.
    code = ("import ctypes, time\n"
            "class TS(ctypes.Structure): _fields_ = [('s', ctypes.c_long), ('ns', ctypes.c_long)]\n"
            "t = time.monotonic(); time.sleep(0.15); a = time.monotonic() - t\n"
            "t = time.monotonic()\n"
            "ctypes.CDLL(None).nanosleep(ctypes.byref(TS(0, 150000000)), None)\n"
            "b = time.monotonic() - t\n"
            "print(a, b, ctypes.CDLL(None).pcbdata_fastwait_shortened())\n")
    env = {**os.environ, "LD_PRELOAD": fastwait.library_path()}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    assert float(out[0]) >= 0.15 and float(out[1]) >= 0.15
    assert out[2] == "0"


def _assert_parity(paths) -> None:
    start = time.monotonic()
    result = drc_parity(paths)
    slow, fast = result["slow"], result["fast"]
    assert not any(r["preloaded"] for r in slow)
    assert all(r["preloaded"] for r in fast), "workers did not load the preload"
    assert sum(r["shortened"] for r in fast) > 0, "no KiCad sleep was cut short"
    assert result["different"] == [], "the preload changed these boards' DRC"
    print(f"{len(paths)} boards: {result['identical']} identical, "
          f"{len(result['kicad_varies'])} within KiCad's own run-to-run variation; DRC "
          f"{sum(r['seconds'] for r in slow):.1f} s without, "
          f"{sum(r['seconds'] for r in fast):.1f} s "
          f"with ({time.monotonic() - start:.1f} s wall)")


@needs_library
def test_same_violations_on_routed_d2_test_boards(tmp_path):
    from pcbdata.generators.d2 import D2Generator
    from pcbdata.sets.presets import level

    level = level("d2", "default")
    generator = D2Generator(level.params)
    paths = [str(write_board(tmp_path / f"board_{i:05d}",
                             with_straight_tracks(generator.generate(level.seed, "test", i).board)))
             for i in D2_SAMPLE]
    _assert_parity(paths)


def _smallest_real_boards(count: int) -> list[str]:
    with tarfile.open(SHARED_PCBENCH) as archive:
        boards = [m for m in archive.getmembers() if m.name.endswith("/processed.kicad_pcb")]
        return [m.name for m in sorted(boards, key=lambda m: (m.size, m.name))[:count]]


@needs_library
def test_same_violations_on_real_d3_boards(tmp_path):
    if not SHARED_PCBENCH.is_file():
        skip_without_snapshot(f"real-corpus parity needs the PCBench snapshot at "
                              f"{SHARED_PCBENCH} (absent on this machine)")
    names = _smallest_real_boards(D3_SAMPLE * 40)
    subprocess.run(["tar", "-xJf", str(SHARED_PCBENCH), "-C", str(tmp_path), *names], check=True)
    with_tracks = [str(tmp_path / n) for n in names if (tmp_path / n).read_text(
        errors="replace").count("(segment") >= MIN_TRACKS][:D3_SAMPLE]
    assert len(with_tracks) == D3_SAMPLE
    _assert_parity(with_tracks)


@needs_library
def test_every_pool_preloads_it_unless_turned_off(monkeypatch):
    from pcbdata.kicad import KicadPool

    monkeypatch.delenv(fastwait.SWITCH, raising=False)
    with KicadPool(workers=1, task_timeout=60) as pool:
        assert pool.call("pcbdata.kicad.fastwait:shortened_sleeps") is not None
    monkeypatch.setenv(fastwait.SWITCH, "0")
    with KicadPool(workers=1, task_timeout=60) as pool:
        assert pool.call("pcbdata.kicad.fastwait:shortened_sleeps") is None

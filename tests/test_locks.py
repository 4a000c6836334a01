"""One process at a time per folder: a second build into a set folder, or a second eval into
a REPORT folder, waits for the first (saying so) instead of mixing its files with it."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pcbdata.core.fsutil import folder_lock
from pcbdata.testing.sets import seal_set
from tests.processes import marked_env, new_marker, wait_for

REPO = Path(__file__).resolve().parents[1]


def pcbdata(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "pcbdata", *args], cwd=REPO,
                            env=marked_env(new_marker()), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def finish(proc: subprocess.Popen, timeout: float = 300) -> tuple[int, str]:
    _, err = proc.communicate(timeout=timeout)
    return proc.returncode, err


def read_until(proc: subprocess.Popen, text: str, timeout: float = 60) -> list[str]:
    """Lines of the process's stderr up to the first holding `text` (fails on exit first)."""
    lines: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            raise AssertionError(f"exited before printing {text!r}: {''.join(lines)}")
        lines.append(line)
        if text in line:
            return lines
    raise AssertionError(f"no {text!r} within {timeout} s: {''.join(lines)}")


def build_d2(out: Path, split: str, count: int = 24, *options: str) -> subprocess.Popen:
    return pcbdata("build", "d2", "--splits", split, "--count", str(count), "--workers", "2",
                   "--out", str(out), *options)


def test_a_lock_waits_for_its_holder_and_dies_with_it(tmp_path):
    code = ("import time\nfrom pcbdata.core.fsutil import folder_lock\n"
            f"with folder_lock({str(tmp_path)!r}):\n    print('held', flush=True)\n"
            "    time.sleep(600)\n")
    holder = subprocess.Popen([sys.executable, "-c", code], cwd=REPO, stdout=subprocess.PIPE,
                              text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        messages: list[str] = []
        waiter = _acquire_in_thread(tmp_path, messages)
        assert wait_for(lambda: messages, 10) == [(
            f"{tmp_path} is being built by another process (pid {holder.pid}); waiting for it "
            f"to finish")]
        assert waiter.is_alive()
        holder.send_signal(signal.SIGKILL)  # the kernel drops a dead holder's lock
        waiter.join(10)
        assert not waiter.is_alive()
    finally:
        holder.kill()
        holder.wait()


def _acquire_in_thread(folder: Path, messages: list[str]):
    import threading

    def acquire() -> None:
        with folder_lock(folder, report=messages.append):
            pass

    thread = threading.Thread(target=acquire, daemon=True)
    thread.start()
    return thread


def test_a_build_waits_for_the_folder_and_writes_nothing_meanwhile(tmp_path):
    out = tmp_path / "set"
    with folder_lock(out):
        proc = build_d2(out, "test", 8, "--no-check")
        line = read_until(proc, "is being built by another process")[-1]
        assert line.startswith(f"pcbdata: {out} is being built by another process "
                               f"(pid {os.getpid()})")
        time.sleep(1)
        assert sorted(p.name for p in out.iterdir()) == [".pcbdata"]
    code, err = finish(proc)
    assert code == 0, err
    assert json.loads((out / "manifest.json").read_text())["configs"]["d2"]["splits"].keys() \
        == {"test"}


def test_two_builds_of_different_splits_into_one_folder_both_land(tmp_path):
    out = tmp_path / "set"
    first, second = build_d2(out, "test"), build_d2(out, "validation")
    results = [finish(first), finish(second)]
    assert [code for code, _ in results] == [0, 0], results
    manifest = json.loads((out / "manifest.json").read_text())
    assert set(manifest["configs"]["d2"]["splits"]) == {"test", "validation"}
    verify = subprocess.run([sys.executable, "-m", "pcbdata", "verify", str(out)], cwd=REPO,
                            capture_output=True, text=True, check=False)
    assert verify.returncode == 0, verify.stdout + verify.stderr


def test_another_builds_writability_probe_is_not_content(tmp_path):
    """Two builds started together: the first proves the new folder writable with a probe file
    that the second must not take for foreign content (the cause of a refused second build)."""
    from pcbdata.build.synthetic import check_root
    from pcbdata.core.errors import UserError
    from pcbdata.core.fsutil import PROBE_PREFIX

    out = tmp_path / "set"
    out.mkdir()
    (out / f"{PROBE_PREFIX}x1y2.tmp").write_bytes(b"")
    assert check_root(out) == out
    (out / "notes.txt").write_text("mine")
    with pytest.raises(UserError, match="is not a pcbdata board set"):
        check_root(out)


def test_two_builds_of_one_split_started_apart_both_succeed(tmp_path):
    out = tmp_path / "set"
    first = build_d2(out, "test", 64, "--no-check")
    time.sleep(2.5)
    second = build_d2(out, "test", 64, "--no-check")
    results = [finish(first), finish(second)]
    assert [code for code, _ in results] == [0, 0], results


def test_a_d3_build_waits_for_the_folder(tmp_path):
    from tests.curation.corpus_fixture import fixture_recipe, make_corpus

    source = make_corpus(tmp_path / "src")
    out = tmp_path / "d3"
    with folder_lock(out):
        proc = pcbdata("build", "d3", "--source", str(source), "--out", str(out), "--recipe",
                       str(fixture_recipe(tmp_path / "recipe.toml")), "--workers", "1")
        try:
            read_until(proc, f"{out} is being built by another process (pid {os.getpid()})")
            time.sleep(1)
            assert sorted(p.name for p in out.iterdir()) == [".pcbdata"]
        finally:
            proc.kill()
            proc.communicate()


@pytest.fixture
def eval_inputs(tmp_path):
    from tests.evaluator.boards import (
        ROUTE_A,
        ROUTE_B,
        base_board,
        routed,
        write_board,
        write_instance,
    )

    root = tmp_path / "set"
    runs = tmp_path / "runs"
    for board_id in ("b0", "b1"):
        write_instance(base_board(), root / "d2" / "test" / board_id)
        write_board(routed(base_board(), [ROUTE_A]), runs / board_id / "0.kicad_pcb")
        write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), runs / board_id / "1.kicad_pcb")
    return seal_set(root), runs


def test_an_eval_waits_for_its_report_folder(eval_inputs, tmp_path):
    root, runs = eval_inputs
    report = tmp_path / "report"
    with folder_lock(report):
        proc = pcbdata("eval", str(root), "--config", "d2", "--runs", str(runs), "--out",
                       str(report), "--workers", "1", "--k", "1")
        read_until(proc, f"{report} is being written by another process (pid {os.getpid()})")
        time.sleep(1)
        assert sorted(p.name for p in report.iterdir()) == [".pcbdata"]
    code, err = finish(proc)
    assert code == 0, err
    assert json.loads((report / "summary.json").read_text())["n_rollouts"] == 2

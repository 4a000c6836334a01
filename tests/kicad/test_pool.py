"""The worker pool turns crashes, hangs, runaway memory and exceptions into recorded reasons
and goes on; its workers start without re-importing the caller and never outlive it."""
import ctypes.util
import signal
import subprocess
import sys
import time

import pytest

from pcbdata.kicad import KicadError, KicadPool
from tests.processes import marked_env, marked_processes, new_marker, wait_for


def test_crash_timeout_and_exception_become_reasons_and_other_tasks_go_on():
    with KicadPool(workers=2, task_timeout=3) as pool:
        tasks = [("os:abort", ()), ("time:sleep", (30,)), ("math:sqrt", (-1,)),
                 ("math:sqrt", (16,)), ("math:sqrt", (25,))]
        outcomes = {o.index: o for o in pool.map(tasks[0][0], [()])}  # abort alone first
        assert not outcomes[0].ok and "worker crashed (SIGABRT)" in outcomes[0].error
        outcomes = {o.index: o for o in pool.map("time:sleep", [(30,), (0,)])}
        assert not outcomes[0].ok and "time limit of 3 s exceeded" in outcomes[0].error
        assert outcomes[1].ok
        outcomes = {o.index: o for o in pool.map("math:sqrt", [(-1,), (16,), (25,)])}
        assert not outcomes[0].ok and "ValueError" in outcomes[0].error
        assert (outcomes[1].value, outcomes[2].value) == (4.0, 5.0)


def test_workers_are_recycled_after_their_task_budget():
    with KicadPool(workers=1, task_timeout=30, tasks_per_worker=2) as pool:
        pids = [o.value for o in pool.map("os:getpid", [()] * 6)]
    assert len(set(pids)) == 3


def test_back_to_back_calls_never_meet_a_worker_being_recycled():
    # A worker recycled after the outcome was handed over was still stopping when the next
    # call sent it a task: "worker exited with code 0".
    with KicadPool(workers=1, task_timeout=30, tasks_per_worker=1) as pool:
        pids = [pool.call("os:getpid") for _ in range(8)]
    assert len(set(pids)) == 8


def test_call_raises_engine_error_with_the_reason(tmp_path):
    with KicadPool(workers=1, task_timeout=30) as pool:
        try:
            pool.call("pcbdata.kicad.basics:drc", str(tmp_path / "missing.kicad_pcb"))
        except KicadError as exc:
            assert "no such board file" in str(exc)
        else:
            raise AssertionError("expected KicadError")


# --- tasks the tests run in workers (importable there as tests.kicad.test_pool:...) ---

def allocate_and_wait(mib: int) -> int:
    """Touches `mib` MiB (a filled bytes object, so the pages are resident), then waits."""
    data = b"x" * (mib << 20)
    time.sleep(30)
    return len(data)


def loaded_libraries() -> str:
    with open("/proc/self/maps", encoding="utf-8") as handle:
        return handle.read()


def test_memory_limit_is_a_named_failure_and_the_worker_is_replaced():
    with KicadPool(workers=1, task_timeout=60, memory_limit_mb=200) as pool:
        first = pool.call("os:getpid")
        start = time.monotonic()
        outcome = next(pool.map("tests.kicad.test_pool:allocate_and_wait", [(400,)]))
        assert not outcome.ok and outcome.error == "memory limit of 200 MiB exceeded"
        assert time.monotonic() - start < 20  # stopped when it grew, not at the time limit
        assert pool.call("os:getpid") != first  # a fresh worker took over


def test_memory_limit_default_and_environment_variable(monkeypatch):
    from pcbdata.core.errors import UserError

    monkeypatch.delenv("PCBDATA_WORKER_MEMORY_MB", raising=False)
    assert KicadPool(workers=1).memory_limit_mb == 4096
    monkeypatch.setenv("PCBDATA_WORKER_MEMORY_MB", "123")
    assert KicadPool(workers=1).memory_limit_mb == 123
    assert KicadPool(workers=1, memory_limit_mb=0).memory_limit_mb == 0  # no limit
    monkeypatch.setenv("PCBDATA_WORKER_MEMORY_MB", "lots")
    with pytest.raises(UserError, match="PCBDATA_WORKER_MEMORY_MB"):
        KicadPool(workers=1)


def test_env_is_applied_when_the_worker_starts():
    """LD_PRELOAD only works if the variable is set before the worker's interpreter starts."""
    library = ctypes.util.find_library("sqlite3")  # present wherever Python has sqlite3
    assert library
    with KicadPool(workers=1, task_timeout=60, env={"LD_PRELOAD": library}) as pool:
        assert library in pool.call("tests.kicad.test_pool:loaded_libraries")
    with KicadPool(workers=1, task_timeout=60) as pool:
        assert library not in pool.call("tests.kicad.test_pool:loaded_libraries")


def test_a_plain_script_can_use_the_pool_and_score_at_module_level(tmp_path):
    """No `if __name__ == "__main__"` guard: workers must not re-import the script."""
    from tests.evaluator.boards import (
        ROUTE_A,
        ROUTE_B,
        base_board,
        routed,
        write_board,
        write_instance,
    )

    instance = write_instance(base_board(), tmp_path / "instance")
    board = write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), tmp_path / "routed.kicad_pcb")
    script = tmp_path / "plain_script.py"
    script.write_text(
        "import os\n"
        "from pcbdata.evaluator import score\n"
        "from pcbdata.kicad import KicadPool\n"
        "with KicadPool(workers=1, task_timeout=60) as pool:\n"
        "    print('other process:', pool.call('os:getpid') != os.getpid())\n"
        f"record = score({str(instance)!r}, {str(board)!r})\n"
        "print('scored:', record['status'], record['cp'], record['wl'])\n")
    marker = new_marker()
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=150, cwd=tmp_path, env=marked_env(marker), check=False)
    assert proc.returncode == 0, proc.stderr
    assert "other process: True" in proc.stdout
    assert "scored: ok 1 80.0" in proc.stdout


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_a_busy_worker_dies_with_its_parent(tmp_path, sig):
    """A worker in the middle of a long task (a KiCad hang) ends when its parent is killed."""
    script = tmp_path / "parent.py"
    script.write_text("from pcbdata.kicad import KicadPool\n"
                      "KicadPool(workers=1, task_timeout=600).call('time:sleep', 600)\n")
    marker = new_marker()
    parent = subprocess.Popen([sys.executable, str(script)], env=marked_env(marker),
                              stderr=subprocess.DEVNULL)
    try:
        workers = wait_for(lambda: {p: c for p, c in marked_processes(marker).items()
                                    if p != parent.pid and "pcbdata.kicad.worker" in c}, 60)
        assert workers, "the worker never started"
        time.sleep(0.5)  # the worker is inside its task now
        parent.send_signal(sig)
        parent.wait(10)
        assert wait_for(lambda: not marked_processes(marker), 5), marked_processes(marker)
    finally:
        parent.kill()
        parent.wait()


def test_a_caller_that_stops_early_never_gets_its_answers_in_the_next_call():
    # The first map's other task was still running in its worker when the caller moved on;
    # the next map sent that worker a task and read the earlier task's answer as its own.
    with KicadPool(workers=2, task_timeout=30) as pool:
        slow = [(f"sleep {0.2 * n}; echo {n}",) for n in range(1, 5)]
        for _ in pool.map("subprocess:getoutput", slow):
            break
        assert sorted(o.value for o in pool.map("math:sqrt", [(16,), (25,)])) == [4.0, 5.0]


def test_resident_memory_of_the_running_workers():
    with KicadPool(workers=1, task_timeout=30) as pool:
        assert pool.resident_mib() == 0  # workers start with their first task
        pool.call("os:getpid")
        assert pool.resident_mib() > 1
    assert pool.resident_mib() == 0

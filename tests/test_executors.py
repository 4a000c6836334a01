"""The executor seam (`pcbdata.executors`): the Ray executor runs the same tasks as the local
one, inside a KicadPool worker on the node, with its limits, and survives a dying worker."""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

from pcbdata.core.errors import UserError
from pcbdata.executors import LOCAL, RayExecutor, get_executor, resolve
from pcbdata.kicad.pool import KicadPool


def die_once(marker: str, value: int) -> int:
    """Task: the first time, kills the Ray worker process that runs this task's KiCad worker
    (as when its node dies); the run Ray makes again returns `value`."""
    if not os.path.exists(marker):
        Path(marker).write_text("died once")
        os.kill(os.getppid(), signal.SIGKILL)
        time.sleep(60)
    return value


def pids(_: int) -> tuple[int, int]:
    """Task: (this KiCad worker's pid, its parent's: the Ray worker or the local caller)."""
    return os.getpid(), os.getppid()


def fail(message: str) -> None:
    raise ValueError(message)


def test_executors_by_name():
    assert resolve(None) is LOCAL and resolve("local") is LOCAL
    assert get_executor("ray", "10.0.0.1:6379") == RayExecutor("10.0.0.1:6379")
    with pytest.raises(UserError, match="unknown executor 'dask'"):
        get_executor("dask")
    with LOCAL.pool(workers=1, task_timeout=5) as pool:
        assert isinstance(pool, KicadPool) and pool.task_timeout == 5


def test_without_ray_the_ray_executor_is_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if not installed
    with pytest.raises(UserError, match=r"needs Ray: pip install 'pcbdata\[ray\]'"):
        RayExecutor().pool()


def test_ray_tasks_run_in_kicad_workers_under_the_limits(ray_cluster):
    with RayExecutor().pool(task_timeout=20.0) as pool:  # the first task starts a KiCad worker
        assert pool.workers == 2
        outcomes = sorted(pool.map("tests.test_executors:pids", [(i,) for i in range(4)]),
                          key=lambda o: o.index)
        assert [o.index for o in outcomes] == [0, 1, 2, 3] and all(o.ok for o in outcomes)
        for outcome in outcomes:  # a KiCad worker whose parent is a Ray worker, not us
            worker, parent = outcome.value
            assert parent != os.getpid() and worker != os.getpid()
        # A short limit for the task that must hit it (the suite waits for it); the new
        # limit starts a new KiCad worker, and the generous one returns for the tasks after.
        pool.task_timeout = 2.0
        [slow] = pool.map("time:sleep", [(30,)])
        assert not slow.ok and slow.error == "time limit of 2 s exceeded"
        pool.task_timeout = 20.0
        [bad] = pool.map("tests.test_executors:fail", [("no good",)])
        assert not bad.ok and bad.error == "ValueError: no good"
        [ok] = pool.map("tests.test_executors:pids", [(0,)])  # the pool goes on
        assert ok.ok
        with pytest.raises(Exception, match="no good"):
            pool.call("tests.test_executors:fail", "no good")


def test_many_tasks_go_in_batches_and_each_has_its_outcome(ray_cluster):
    with RayExecutor().pool(task_timeout=30) as pool:
        assert (pool.batch_size(10**6), pool.batch_size(40), pool.batch_size(7)) == (16, 5, 1)
        args: list[tuple] = [(i,) for i in range(40)]
        args[17] = (threading.Lock(),)  # does not pickle: its batch goes task by task
        outcomes = sorted(pool.map("tests.test_executors:pids", args), key=lambda o: o.index)
    assert [o.index for o in outcomes] == list(range(40))
    assert not outcomes[17].ok and outcomes[17].error.startswith("task not run: ")
    assert all(o.ok for o in outcomes if o.index != 17)
    assert len({o.value[1] for o in outcomes if o.ok}) <= 3  # Ray workers, not 40 processes


def test_a_task_whose_worker_dies_runs_again(ray_cluster, tmp_path):
    with RayExecutor().pool(task_timeout=60) as pool:
        [outcome] = pool.map("tests.test_executors:die_once", [(str(tmp_path / "m"), 7)])
    assert outcome.ok and outcome.value == 7
    assert (tmp_path / "m").read_text() == "died once"
    with RayExecutor(max_retries=0).pool(task_timeout=60) as pool:
        [lost] = pool.map("tests.test_executors:die_once", [(str(tmp_path / "n"), 7)])
    assert not lost.ok and lost.error.startswith("ray: ")

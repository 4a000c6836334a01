"""The worker pool turns crashes, hangs and exceptions into recorded reasons and goes on."""
from pcbdata.kicad import KicadError, KicadPool


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


def test_call_raises_engine_error_with_the_reason(tmp_path):
    with KicadPool(workers=1, task_timeout=30) as pool:
        try:
            pool.call("pcbdata.kicad.basics:drc", str(tmp_path / "missing.kicad_pcb"))
        except KicadError as exc:
            assert "no such board file" in str(exc)
        else:
            raise AssertionError("expected KicadError")

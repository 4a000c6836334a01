"""Long-lived KiCad worker processes with per-task time and memory limits.

KiCad can crash the interpreter (segfault), hang or run away with memory on some boards, and
some edits leave a `pcbnew` process damaged. Each task therefore runs in a separate worker
process; a task that crashes its worker or exceeds its time or memory limit becomes a failed
`Outcome` with the reason, the worker is replaced, and the other tasks go on. Workers are
recycled after a number of tasks so that memory KiCad keeps between boards is given back.

Workers are fresh interpreters started by fork + exec (`python -m pcbdata.kicad.worker`, see
there): they never re-import the caller's `__main__` (a plain script may call the pool at
module level), create no multiprocessing resource tracker, get the pool's `env` at exec time
(so e.g. `LD_PRELOAD` takes effect) and die with the process that started them.
"""
from __future__ import annotations

import os
import queue
import shutil
import signal
import site
import subprocess
import sys
import threading
import time
import weakref
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from multiprocessing import Pipe
from pathlib import Path
from typing import Any

from pcbdata.core.fsutil import owned_temp_folder
from pcbdata.kicad import fastwait

#: Default memory limit of one worker (resident set), in MiB; 0 means no limit.
DEFAULT_MEMORY_LIMIT_MB = 4096
MEMORY_ENV = "PCBDATA_WORKER_MEMORY_MB"
_POLL_SECONDS = 0.2  # how often a waiting task checks its worker's life and memory
_PACKAGE_ROOT = str(Path(__file__).resolve().parents[2])  # the folder holding `pcbdata/`


@dataclass
class Outcome:
    index: int
    ok: bool
    value: Any = None
    error: str = ""
    seconds: float = 0.0


def time_limit_error(seconds: float) -> str:
    return f"time limit of {seconds:g} s exceeded"


def memory_limit_error(mib: int) -> str:
    return f"memory limit of {mib} MiB exceeded"


def is_limit_error(error: str) -> bool:
    """Whether a failure is a time or memory limit (a verdict worth caching by input hash),
    rather than a crash, which may not recur."""
    return error.startswith(("time limit of ", "memory limit of "))


def memory_limit_from_env(value: int | None = None) -> int:
    """`value`, else PCBDATA_WORKER_MEMORY_MB, else the default; 0 (or less) means no limit."""
    if value is not None:
        return max(0, int(value))
    text = os.environ.get(MEMORY_ENV, "").strip()
    if not text:
        return DEFAULT_MEMORY_LIMIT_MB
    try:
        return max(0, int(text))
    except ValueError:
        from pcbdata.core.errors import UserError

        raise UserError(f"{MEMORY_ENV}={text!r}: expected a whole number of MiB "
                        f"(0 for no limit)") from None


def _resident_mib(pid: int) -> int:
    """Resident memory of a process in MiB (0 when it is gone)."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii", errors="replace") as handle:
            for line in handle:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) // 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _describe_exit(code: int | None) -> str:
    if code is None:
        return "worker stopped responding"
    if code < 0:
        try:
            return f"worker crashed ({signal.Signals(-code).name})"
        except ValueError:
            return f"worker crashed (signal {-code})"
    return f"worker exited with code {code}"


class _Launcher:
    """Starts every worker from one daemon thread that lives as long as the process.

    PR_SET_PDEATHSIG fires when the *thread* that started a worker ends, not the process, and
    the threads that serve a `map` end with it. A daemon thread is never joined at interpreter
    exit, so workers die exactly when this process does.
    """

    def __init__(self) -> None:
        self.pid = os.getpid()
        self._requests: queue.Queue = queue.Queue()
        threading.Thread(target=self._serve, name="pcbdata-launcher", daemon=True).start()

    def _serve(self) -> None:
        while True:
            argv, options, reply = self._requests.get()
            try:
                reply.put((True, subprocess.Popen(argv, **options)))
            except BaseException as exc:  # noqa: BLE001 - handed to the caller
                reply.put((False, exc))

    def launch(self, argv: list[str], **options) -> subprocess.Popen:
        reply: queue.Queue = queue.Queue(maxsize=1)
        self._requests.put((argv, options, reply))
        ok, value = reply.get()
        if not ok:
            raise value
        return value


_launcher: _Launcher | None = None
_launcher_guard = threading.Lock()


def _launch(argv: list[str], **options) -> subprocess.Popen:
    global _launcher
    with _launcher_guard:
        if _launcher is None or _launcher.pid != os.getpid():  # none yet, or we were forked
            _launcher = _Launcher()
        launcher = _launcher
    return launcher.launch(argv, **options)


def _worker_env(env: dict[str, str]) -> dict[str, str]:
    """The caller's environment plus `env`; a source tree of pcbdata that is not installed
    (imported from the current folder, say) is put on the worker's PYTHONPATH."""
    merged = {**os.environ, **env}
    site_dirs = {os.path.realpath(p) for p in site.getsitepackages() + [site.getusersitepackages()]}
    if os.path.realpath(_PACKAGE_ROOT) not in site_dirs:
        merged["PYTHONPATH"] = os.pathsep.join(
            p for p in (_PACKAGE_ROOT, merged.get("PYTHONPATH", "")) if p)
    return merged


class _Worker:
    def __init__(self, env: dict[str, str], memory_limit_mb: int):
        self._env = env
        self.memory_limit_mb = memory_limit_mb
        self.proc: Any = None  # subprocess.Popen while a worker runs
        self.conn: Any = None  # multiprocessing.connection.Connection to it
        self.tasks_done = 0
        self.closed = False

    def ensure_started(self) -> None:
        if self.closed:
            raise RuntimeError("the pool is closed")
        if self.proc is not None and self.proc.poll() is None:
            return
        env = _worker_env(self._env)
        parent, child = Pipe(duplex=True)  # a socket pair
        # -P: the worker's working directory must not shadow the pcbdata it runs
        argv = [sys.executable, "-P", "-m", "pcbdata.kicad.worker", str(child.fileno()),
                str(os.getpid())]
        log = env.get("PCBDATA_ENGINE_LOG")  # KiCad/wx chatter: a log file or nowhere
        self.proc = None
        try:
            with open(log or os.devnull, "ab") as output:
                self.proc = _launch(argv, env=env, pass_fds=(child.fileno(),),
                                    stdin=subprocess.DEVNULL, stdout=output, stderr=output,
                                    process_group=0)  # kill() takes the worker's children too
        except BaseException:
            parent.close()
            raise
        finally:
            child.close()
        self.conn = parent
        self.conn.send(list(sys.path))
        self.tasks_done = 0

    def run(self, ref: str, args: tuple, timeout: float) -> tuple[bool, Any]:
        try:
            self.ensure_started()
        except OSError as exc:
            return False, f"worker could not start: {exc}"
        try:
            self.conn.send((ref, args))
            deadline = time.monotonic() + timeout
            # Poll in slices: a worker that dies without closing the socket, outgrows its
            # memory limit or exceeds the time limit is stopped and reported at once.
            while not self.conn.poll(min(_POLL_SECONDS, max(0.0, deadline - time.monotonic()))):
                if self.proc.poll() is not None:
                    raise EOFError
                limit = self.memory_limit_mb
                if limit and _resident_mib(self.proc.pid) > limit:
                    self.kill()
                    return False, memory_limit_error(limit)
                if time.monotonic() >= deadline:
                    self.kill()
                    return False, time_limit_error(timeout)
            ok, value = self.conn.recv()
        except (EOFError, OSError):
            reason = self._exit_reason()
            self.kill()
            return False, reason
        self.tasks_done += 1
        return ok, value

    def _exit_reason(self) -> str:
        try:
            self.proc.wait(5)
        except subprocess.TimeoutExpired:
            pass
        return _describe_exit(self.proc.returncode)

    def kill(self) -> None:
        if self.proc is not None:
            if self.proc.poll() is None:
                try:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                except OSError:
                    self.proc.kill()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                pass
            self.conn.close()
        self.proc = None

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            try:
                self.conn.send(None)
                self.proc.wait(10)
            except (OSError, subprocess.TimeoutExpired):
                pass
        self.kill()


class KicadPool:
    """Runs `module:function` tasks in `workers` worker processes.

    `map` yields one `Outcome` per argument tuple as tasks finish (not in input order).
    `task_timeout` (seconds) and `memory_limit_mb` (resident memory of one worker; None: the
    PCBDATA_WORKER_MEMORY_MB variable, else 4096; 0: no limit) turn a hung or runaway task
    into a failed outcome. `env` is added to the workers' environment when they start.
    """

    def __init__(self, workers: int | None = None, task_timeout: float = 120.0,
                 tasks_per_worker: int = 250, env: dict[str, str] | None = None,
                 memory_limit_mb: int | None = None):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.task_timeout = task_timeout
        self.tasks_per_worker = tasks_per_worker
        self.memory_limit_mb = memory_limit_from_env(memory_limit_mb)
        # Workers' temporary files live in a folder of the pool's, removed when it closes: a
        # worker killed at its time limit cannot clean up after itself.
        self._tmp = owned_temp_folder("pool")
        self._cleanup = weakref.finalize(self, shutil.rmtree, self._tmp, True)
        # KiCad's DRC sleeps 250 ms per call without it (fastwait.py); `env` may turn it off
        env = {"TMPDIR": self._tmp, **fastwait.preload_env(), **(env or {})}
        self._slots = [_Worker(env, self.memory_limit_mb)
                       for _ in range(self.workers)]

    def __enter__(self) -> KicadPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        for slot in self._slots:
            slot.closed = True
            slot.stop()
        self._cleanup()

    def resident_mib(self) -> int:
        """The resident memory of the largest running worker, in MiB (0: none is running)."""
        return max((_resident_mib(slot.proc.pid) for slot in self._slots
                    if slot.proc is not None and slot.proc.poll() is None), default=0)

    def map(self, ref: str, arg_tuples: Iterable[tuple]) -> Iterator[Outcome]:
        todo: queue.Queue = queue.Queue()
        count = 0
        for count, args in enumerate(arg_tuples, start=1):
            todo.put((count - 1, tuple(args)))
        done: queue.Queue = queue.Queue()

        def serve(slot: _Worker) -> None:
            while True:
                try:
                    index, args = todo.get_nowait()
                except queue.Empty:
                    return
                start = time.perf_counter()
                try:
                    ok, value = slot.run(ref, args, self.task_timeout)
                except Exception as exc:  # noqa: BLE001 - e.g. arguments that do not pickle
                    slot.kill()
                    ok, value = False, f"task not run: {type(exc).__name__}: {exc}"
                seconds = time.perf_counter() - start
                # Recycle before reporting: a caller that gets its last outcome may start the
                # next map at once, and must not find this slot's worker half stopped.
                if slot.tasks_done >= self.tasks_per_worker:
                    slot.stop()
                done.put(Outcome(index, ok, value if ok else None, "" if ok else str(value),
                                 seconds))

        if count == 1:  # one task (e.g. each environment step): no thread to start and join
            serve(self._slots[0])
            yield done.get()
            return
        threads = [threading.Thread(target=serve, args=(slot,), daemon=True)
                   for slot in self._slots[: max(1, min(self.workers, count))]]
        for thread in threads:
            thread.start()
        try:
            for _ in range(count):
                yield done.get()
        finally:  # a caller that stops early: queued tasks are dropped, not started, and the
            while not todo.empty():  # running ones end before a next call uses their workers
                try:
                    todo.get_nowait()
                except queue.Empty:
                    break
            for thread in threads:
                thread.join()

    def call(self, ref: str, *args) -> Any:
        """Runs one task and returns its value; raises `KicadError` on failure."""
        [outcome] = list(self.map(ref, [args]))  # to the end: its thread is joined
        if not outcome.ok:
            raise KicadError(outcome.error)
        return outcome.value


class KicadError(RuntimeError):
    pass

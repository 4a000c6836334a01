"""Long-lived KiCad worker processes with per-task time limits.

KiCad can crash the interpreter (segfault) or hang on some boards, and some edits leave a
`pcbnew` process damaged. Each task therefore runs in a separate worker process; a task that
crashes its worker or exceeds its time limit becomes a failed `Outcome` with the reason, the
worker is replaced, and the other tasks go on. Workers are recycled after a number of tasks so
that memory KiCad keeps between boards is given back.
"""
from __future__ import annotations

import importlib
import multiprocessing
import os
import queue
import signal
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

_CTX = multiprocessing.get_context("spawn")


@dataclass
class Outcome:
    index: int
    ok: bool
    value: Any = None
    error: str = ""
    seconds: float = 0.0


def _resolve(ref: str) -> Callable:
    module, _, name = ref.partition(":")
    return getattr(importlib.import_module(module), name)


def _silence_output() -> None:
    """KiCad/wx write debug chatter to the process's stdout/stderr; send it to a log file
    (PCBDATA_ENGINE_LOG) or nowhere. Failures still reach the parent as recorded reasons."""
    target = os.environ.get("PCBDATA_ENGINE_LOG") or os.devnull
    fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)


def _worker_main(conn, env: dict[str, str]) -> None:
    os.environ.update(env)
    _silence_output()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when workers stop
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        ref, args = message
        try:
            conn.send((True, _resolve(ref)(*args)))
        except BaseException as exc:  # noqa: BLE001 - every failure becomes a recorded reason
            detail = "".join(traceback.format_exception_only(type(exc), exc)).strip()
            conn.send((False, detail))


def _describe_exit(code: int | None) -> str:
    if code is None:
        return "worker stopped responding"
    if code < 0:
        try:
            return f"worker crashed ({signal.Signals(-code).name})"
        except ValueError:
            return f"worker crashed (signal {-code})"
    return f"worker exited with code {code}"


class _Worker:
    def __init__(self, env: dict[str, str]):
        self._env = env
        self.proc = None
        self.conn = None
        self.tasks_done = 0

    def ensure_started(self) -> None:
        if self.proc is None or not self.proc.is_alive():
            parent, child = _CTX.Pipe()
            self.proc = _CTX.Process(target=_worker_main, args=(child, self._env), daemon=True)
            self.proc.start()
            child.close()
            self.conn = parent
            self.tasks_done = 0

    def run(self, ref: str, args: tuple, timeout: float) -> tuple[bool, Any]:
        self.ensure_started()
        try:
            self.conn.send((ref, args))
            deadline = time.monotonic() + timeout
            # Poll in slices so that a worker that dies without closing the pipe (or never
            # starts, e.g. a script without a __main__ guard) is reported as such at once.
            while not self.conn.poll(min(1.0, max(0.0, deadline - time.monotonic()))):
                if not self.proc.is_alive():
                    raise EOFError
                if time.monotonic() >= deadline:
                    self.kill()
                    return False, f"time limit of {timeout:g} s exceeded"
            ok, value = self.conn.recv()
        except (EOFError, OSError, BrokenPipeError):
            self.proc.join(5)
            reason = _describe_exit(self.proc.exitcode)
            self.kill()
            return False, reason
        self.tasks_done += 1
        return ok, value

    def kill(self) -> None:
        if self.proc is not None:
            if self.proc.is_alive():
                self.proc.kill()
            self.proc.join(5)
            self.conn.close()
        self.proc = None

    def stop(self) -> None:
        if self.proc is not None and self.proc.is_alive():
            try:
                self.conn.send(None)
                self.proc.join(10)
            except (OSError, BrokenPipeError):
                pass
        self.kill()


class KicadPool:
    """Runs `module:function` tasks in `workers` KiCad processes.

    `map` yields one `Outcome` per argument tuple as tasks finish (not in input order).
    """

    def __init__(self, workers: int | None = None, task_timeout: float = 120.0,
                 tasks_per_worker: int = 250, env: dict[str, str] | None = None):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.task_timeout = task_timeout
        self.tasks_per_worker = tasks_per_worker
        self._slots = [_Worker(dict(env or {})) for _ in range(self.workers)]

    def __enter__(self) -> "KicadPool":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        for slot in self._slots:
            slot.stop()

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
                ok, value = slot.run(ref, args, self.task_timeout)
                seconds = time.perf_counter() - start
                done.put(Outcome(index, ok, value if ok else None, "" if ok else str(value),
                                 seconds))
                if slot.tasks_done >= self.tasks_per_worker:
                    slot.stop()

        threads = [threading.Thread(target=serve, args=(slot,), daemon=True)
                   for slot in self._slots[: max(1, min(self.workers, count))]]
        for thread in threads:
            thread.start()
        for _ in range(count):
            yield done.get()
        for thread in threads:
            thread.join()

    def call(self, ref: str, *args) -> Any:
        """Runs one task and returns its value; raises `KicadError` on failure."""
        outcome = next(iter(self.map(ref, [args])))
        if not outcome.ok:
            raise KicadError(outcome.error)
        return outcome.value


class KicadError(RuntimeError):
    pass

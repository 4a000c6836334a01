"""One engine worker process: `python -m pcbdata.kicad.worker FD PARENT_PID`.

`pool.py` starts it with fork + exec of a fresh interpreter (never multiprocessing's spawn,
which re-imports the caller's `__main__`, and never a bare fork: a process forked after KiCad
ran its DRC hangs). FD is this end of a socket pair; messages are pickled by a
`multiprocessing.connection.Connection`:

    parent -> worker   sys.path (first message only), then (ref, args) per task, None to stop
    worker -> parent   (True, value) or (False, "ExceptionType: message")

The worker dies with its parent (PR_SET_PDEATHSIG) and stops at end of file on the socket, so
no worker outlives the run that started it, even when that run is killed.
"""
from __future__ import annotations

import ctypes
import importlib
import os
import signal
import sys
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection

_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int) -> None:
    """Asks Linux to SIGKILL this process when its parent ends: a worker busy in a task (a
    KiCad hang) cannot notice that its parent is gone. Exits at once if it already is."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: end of file on the socket still stops us
        pass
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(0)


def resolve(ref: str) -> Callable:
    module, _, name = ref.partition(":")
    return getattr(importlib.import_module(module), name)


def serve(conn: Connection) -> None:
    """Runs tasks until the parent says stop (None) or goes away (end of file)."""
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        ref, args = message
        try:
            conn.send((True, resolve(ref)(*args)))
        except BaseException as exc:  # noqa: BLE001 - every failure becomes a recorded reason
            detail = "".join(traceback.format_exception_only(type(exc), exc)).strip()
            conn.send((False, detail))


def main(argv: list[str]) -> None:
    fd, parent_pid = int(argv[1]), int(argv[2])
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when workers stop
    conn = Connection(fd)
    try:
        sys.path[:] = conn.recv()  # task modules import from where the caller imports them
    except (EOFError, OSError):
        return
    serve(conn)


if __name__ == "__main__":
    main(sys.argv)

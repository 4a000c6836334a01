"""Crash-safe file output (write to a temporary name in the same folder, then rename) and
the lock that keeps two processes from writing one folder at once."""
from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_bytes, sha256_file  # noqa: F401 - re-exported for callers


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# mkstemp/mkdtemp create private (0600/0700) entries; published sets must be readable by others.
_FILE_MODE = 0o666 & ~_current_umask()
_DIR_MODE = 0o777 & ~_current_umask()


def owned_temp_folder(kind: str) -> str:
    """A new private folder `pcbdata-<kind>-<pid>-XXXXXXXX` in the system temp dir.

    Its owner removes it when done; one killed by a signal cannot, so the folders of the same
    kind whose owning process is gone are removed here first (a process of another user, or
    one still running, keeps its folder)."""
    sweep_owned_temp_folders(kind)
    return tempfile.mkdtemp(prefix=f"pcbdata-{kind}-{os.getpid()}-",
                            dir=tempfile.gettempdir())


def sweep_owned_temp_folders(kind: str) -> int:
    """Removes the `owned_temp_folder`s of `kind` whose owning process is gone; their count."""
    prefix = f"pcbdata-{kind}-"
    removed = 0
    with contextlib.suppress(OSError):
        for entry in Path(tempfile.gettempdir()).iterdir():
            owner = _owner_pid(entry.name, prefix)
            if owner is not None and not _process_exists(owner):
                shutil.rmtree(entry, ignore_errors=True)
                removed += 1
    return removed


def _owner_pid(name: str, prefix: str) -> int | None:
    if not name.startswith(prefix):
        return None
    head, dash, _ = name[len(prefix):].partition("-")  # mkdtemp's own suffix holds no "-"
    return int(head) if dash and head.isdigit() else None


def _process_exists(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def write_atomic(path: str | os.PathLike, data: bytes | str) -> None:
    """Writes `data` to `path` so that a reader (or a killed writer) never sees half a file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        data = data.encode("utf-8")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.chmod(tmp, _FILE_MODE)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_dir_atomic(path: str | os.PathLike, files: dict[str, bytes | str]) -> None:
    """Writes a folder of files so that it appears whole or not at all."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    try:
        for name, data in files.items():
            (tmp / name).write_bytes(data.encode("utf-8") if isinstance(data, str) else data)
        os.chmod(tmp, _DIR_MODE)
        if path.exists():
            shutil.rmtree(path)
        os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def remove_stale_temps(root: str | os.PathLike) -> int:
    """Removes temporary files/folders a killed run left behind; returns how many."""
    count = 0
    for dirpath, dirnames, filenames in os.walk(str(root)):
        for name in list(dirnames):
            if name.startswith(".") and name.endswith(".tmp"):
                shutil.rmtree(os.path.join(dirpath, name), ignore_errors=True)
                dirnames.remove(name)
                count += 1
        for name in filenames:
            if name.startswith(".") and name.endswith(".tmp"):
                os.unlink(os.path.join(dirpath, name))
                count += 1
    return count


LOCK_DIR = ".pcbdata"
LOCK_NAME = "lock"
# The file `output_folder` writes and removes at once to prove a folder writable: another
# process may see it for a moment, and must not take it for content.
PROBE_PREFIX = ".pcbdata-probe."
_held: dict[str, int] = {}  # lock files this process holds -> nesting depth
_held_guard = threading.Lock()


def _report_wait(message: str) -> None:
    print(f"pcbdata: {message}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike, doing: str = "built",
                report: Callable[[str], None] = _report_wait) -> Iterator[Path]:
    """Holds `folder` for one process: an exclusive `flock` on `folder/.pcbdata/lock`.

    Another process holding it makes this one wait (after saying so through `report`, with
    the holder's pid) instead of interleaving its writes. The kernel drops the lock when the
    holder ends, even by SIGKILL, so a killed run never leaves the folder locked. Nested use
    in one process is allowed (a build locks, then calls code that locks again).
    """
    path = Path(folder) / LOCK_DIR / LOCK_NAME
    path.parent.mkdir(parents=True, exist_ok=True)
    key = os.path.realpath(path)
    with _held_guard:
        if _held.get(key):
            _held[key] += 1
            nested = True
        else:
            nested = False
    if nested:
        try:
            yield path
        finally:
            with _held_guard:
                _held[key] -= 1
        return
    with open(path, "a+") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "unknown"
            report(f"{folder} is being {doing} by another process (pid {holder}); "
                   f"waiting for it to finish")
            fcntl.flock(handle, fcntl.LOCK_EX)
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        with _held_guard:
            _held[key] = 1
        try:
            yield path
        finally:
            with _held_guard:
                _held.pop(key, None)
            handle.truncate(0)  # at rest the file is empty: a finished folder is the same
            handle.flush()      # whichever process built it
            fcntl.flock(handle, fcntl.LOCK_UN)


def os_reason(exc: OSError) -> str:
    return exc.strerror or (os.strerror(exc.errno) if exc.errno else str(exc))


def output_folder(path: str | os.PathLike, option: str = "--out") -> Path:
    """Creates `path` (and its parents) if needed and proves a file can be written in it;
    UserError naming the folder and the OS reason otherwise. Folders this made are removed
    again on failure, so a refused run leaves nothing behind."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UserError(f"{option} {path}: exists and is not a folder")
    created = [p for p in (path, *path.parents) if not p.exists()]
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=PROBE_PREFIX, suffix=".tmp", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        for folder in created:  # deepest first
            try:
                folder.rmdir()
            except OSError:
                pass
        raise UserError(f"{option} {path}: cannot write there ({os_reason(exc)})") from None
    return path

"""Checks shared by the verbs: numeric option ranges (as argparse types, so that a bad value
stops the run before anything is read or written) and the writability of an output folder."""
from __future__ import annotations

import argparse
import errno
import math

from pcbdata.build import MAX_WORKERS
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import os_reason, output_folder  # noqa: F401 - re-exported for verbs


def integer(low: int, high: int | None = None, what: str = "an integer"):
    """argparse type: an int in [low, high]."""
    def parse(text: str) -> int:
        try:
            value = int(text, 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if value < low or (high is not None and value > high):
            bound = f">= {low}" if high is None else f"from {low} to {high}"
            raise argparse.ArgumentTypeError(f"must be {what} {bound}, got {value}")
        return value
    return parse


def number(low: float, high: float | None = None, low_open: bool = False):
    """argparse type: a finite float >= low (> low with `low_open`) and <= high."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        bad = (not math.isfinite(value) or value < low or (low_open and value == low)
               or (high is not None and value > high))
        if bad:
            bound = f"> {low:g}" if low_open else f">= {low:g}"
            if high is not None:
                bound += f" and <= {high:g}"
            raise argparse.ArgumentTypeError(f"must be a finite number {bound}, got {text}")
        return value
    return parse


workers = integer(1, MAX_WORKERS)
positive = integer(1)
non_negative = integer(0)
seconds = number(0, low_open=True)
weight = number(0)


def seed(text: str) -> int:
    """argparse type: a seed the whole pipeline can carry (`pcbdata.core.rng.check_seed`)."""
    from pcbdata.core.rng import check_seed

    try:
        value = int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    try:
        return check_seed(value)
    except UserError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


# OS errors that say "this place cannot take the output" (not a bug of pcbdata): they end the
# run with one line instead of a traceback.
WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM,
                errno.ENOTDIR, errno.EISDIR, errno.EFBIG, errno.ENAMETOOLONG, errno.EEXIST}


def write_error_line(exc: OSError, folder: str | None = None) -> str | None:
    """The one-line message for an OS error from writing output, or None (not one of those).
    A failed write() carries no file name: `folder` (the run's output folder) is named then."""
    if exc.errno not in WRITE_ERRNOS:
        return None
    where = exc.filename if exc.filename is not None else (folder or "output")
    return (f"{where}: {os_reason(exc)}; the run stopped (no file is left half-written; run "
            f"the same command again once this is fixed)")

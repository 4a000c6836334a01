"""Progress lines of a build stage on stderr: `  LABEL: done/total (seconds)`, at most one
every two seconds and always the last."""
from __future__ import annotations

import sys
import time


class Progress:
    def __init__(self, label: str, total: int, stream=None):
        self.label, self.total, self.stream = label, total, stream or sys.stderr
        self.done, self.start, self.last = 0, time.perf_counter(), 0.0

    def advance(self, n: int = 1) -> None:
        self.done += n
        now = time.perf_counter()
        if now - self.last >= 2.0 or self.done == self.total:
            self.last = now
            print(f"  {self.label}: {self.done}/{self.total} ({now - self.start:.1f} s)",
                  file=self.stream, flush=True)

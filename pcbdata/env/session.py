"""The environment's side of its KiCad worker: one `KicadPool` worker process (spawned, with a
time limit per task) that holds the board (`pcbdata.kicad.routing_session`)."""
from __future__ import annotations

import shutil
import weakref
from pathlib import Path

from pcbdata.core.fsutil import owned_temp_folder
from pcbdata.env.errors import EngineFailure
from pcbdata.evaluator.metrics import STRICT_WARNINGS
from pcbdata.kicad import fastwait
from pcbdata.kicad.pool import KicadPool

SESSION = "pcbdata.kicad.routing_session"


class KicadSession:
    #: A fresh worker after this many instances, or once it holds this much memory: KiCad
    #: keeps about 0.4-1 MB per board it has loaded, much more on large boards.
    RECYCLE_EVERY = 200
    RECYCLE_MIB = 1536

    def __init__(self, task_timeout: float, env: dict | None = None, fast_drc: bool = True):
        self._task_timeout, self._env = task_timeout, self.worker_env(env, fast_drc)
        self._pool = self._new_pool()
        self._opened = 0
        self.work = Path(owned_temp_folder("env"))  # private: stage, instance
        self.alive = False
        # An environment dropped without close() still stops its worker and removes its folder.
        self._finalizer = weakref.finalize(self, _release, self._pool, str(self.work))

    @staticmethod
    def worker_env(env: dict | None, fast_drc: bool) -> dict:
        """The worker's environment: `env`, and without `fast_drc` an LD_PRELOAD without the
        preload that removes KiCad's 250 ms DRC polling wait (`KicadPool` adds it by default,
        `pcbdata.kicad.fastwait`; an LD_PRELOAD in `env` wins either way)."""
        out = dict(env or {})
        if not fast_drc and "LD_PRELOAD" not in out:
            out.update(fastwait.preload_env(enabled=False))
        return out

    def _new_pool(self) -> KicadPool:
        return KicadPool(workers=1, tasks_per_worker=10**9, task_timeout=self._task_timeout,
                         env=self._env)

    def _call(self, function: str, *args):
        outcome = next(iter(self._pool.map(f"{SESSION}:{function}", [args])))
        if not outcome.ok:
            self.alive = False
            raise EngineFailure(outcome.error or "KiCad worker failed")
        return outcome.value

    def open(self, board: str, project: str, rules: str | None) -> dict:
        """Loads an instance; returns {"static", "snapshot"}. A failure of the previous board's
        worker is forgotten: the pool starts a fresh worker when the old one died."""
        self.alive = False
        self._opened += 1
        if self._opened % self.RECYCLE_EVERY == 0 or \
                self._pool.resident_mib() > self.RECYCLE_MIB:
            self._pool.close()
            self._pool = self._new_pool()
            self._finalizer.detach()
            self._finalizer = weakref.finalize(self, _release, self._pool, str(self.work))
        value = self._call("open_instance", board, project, rules, str(self.work / "stage"),
                           sorted(STRICT_WARNINGS))
        self.alive = True
        return value

    def apply(self, edits: list[dict], drc: bool) -> dict:
        return self._call("apply", edits, drc)

    def prune(self, nets: list[str], drc: bool) -> dict:
        return self._call("prune", list(nets), drc)

    def snapshot(self, drc: bool) -> dict:
        return self._call("snapshot", drc)

    def save(self, path: str) -> str:
        if not self.alive:
            raise EngineFailure("no board is loaded (the worker failed, or reset() was not called)")
        return self._call("save", str(Path(path).resolve()))

    def close(self) -> None:
        self._finalizer()
        self.alive = False


def _release(pool: KicadPool, work: str) -> None:
    pool.close()
    shutil.rmtree(work, ignore_errors=True)

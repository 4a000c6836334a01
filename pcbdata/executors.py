"""Where tasks run: this machine's KiCad worker processes, or a Ray cluster.

Builds (D1/D2 generation and checks, D3), `eval` and rollouts run `module:function` tasks
(importable and picklable, as for `KicadPool`). They get a *pool* from an *executor*:

    pool = executor.pool(workers=8, task_timeout=120.0)   # a TaskPool
    for outcome in pool.map("pcbdata.kicad.basics:drc", arg_tuples): ...

- `LocalExecutor` (the default, `LOCAL`): the pool is a `KicadPool` on this machine.
- `RayExecutor(address)`: tasks go as Ray tasks (one CPU; a few tasks each while much work is
  left, see `RayPool.batch_size`) that run, on whichever node Ray picks, inside a `KicadPool`
  worker kept by that node's Ray worker process: KiCad stays
  in an exec-started process with the same time and memory limits, recycled as locally. A
  node (or Ray worker) that dies mid-task makes Ray run the task again elsewhere
  (`max_retries`); the caller's resumable logs and the outputs it assembles (manifests,
  shards, reports) stay on the driver, which gets the same `Outcome`s as from a `KicadPool`,
  so the outputs are the same bytes. The tasks read and write the paths they are given:
  on a cluster of several machines those folders must be on a filesystem every node mounts
  at the same path (see docs/ray.md).

Ray is optional (`pip install 'pcbdata[ray]'`); it is imported only when a Ray pool starts.
"""
from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

from pcbdata import __version__
from pcbdata.core.errors import UserError
from pcbdata.kicad.pool import KicadError, KicadPool, Outcome, memory_limit_from_env

EXECUTORS = ("local", "ray")
#: Ray tasks in flight per cluster CPU: enough that a node never waits for the driver.
IN_FLIGHT_PER_CPU = 2
#: At most this many tasks go in one Ray task (`RayPool.batch_size`) ...
MAX_BATCH = 16
#: ... while there are this many rounds of the whole cluster's work left.
BATCH_ROUNDS = 4
#: How often Ray runs a task again when its node or worker process dies.
MAX_RETRIES = 3
RAY_INSTALL_HINT = "the Ray executor needs Ray: pip install 'pcbdata[ray]' (or `pip install ray`)"


class TaskPool(Protocol):
    """What builds, eval and rollouts use of a pool (`KicadPool` is one)."""

    workers: int
    task_timeout: float
    memory_limit_mb: int

    def map(self, ref: str, arg_tuples: Iterable[tuple]) -> Iterator[Outcome]: ...

    def call(self, ref: str, *args) -> Any: ...

    def close(self) -> None: ...

    def __enter__(self) -> TaskPool: ...

    def __exit__(self, *exc) -> None: ...


class Executor(Protocol):
    @property
    def name(self) -> str: ...

    def pool(self, workers: int | None = None, task_timeout: float = 120.0,
             tasks_per_worker: int = 250, env: dict[str, str] | None = None,
             memory_limit_mb: int | None = None) -> TaskPool: ...


@dataclass(frozen=True)
class LocalExecutor:
    """This machine's worker processes (`KicadPool`)."""

    name: str = "local"

    def pool(self, workers: int | None = None, task_timeout: float = 120.0,
             tasks_per_worker: int = 250, env: dict[str, str] | None = None,
             memory_limit_mb: int | None = None) -> TaskPool:
        return KicadPool(workers=workers, task_timeout=task_timeout,
                         tasks_per_worker=tasks_per_worker, env=env,
                         memory_limit_mb=memory_limit_mb)


LOCAL = LocalExecutor()


@dataclass(frozen=True)
class RayExecutor:
    """A Ray cluster at `address` (None: `RAY_ADDRESS`, else one `ray start` began on this
    machine, else a new local Ray instance), or the one this process is already connected
    to (`ray.init` called before)."""

    address: str | None = None
    max_retries: int = MAX_RETRIES
    name: str = "ray"

    def pool(self, workers: int | None = None, task_timeout: float = 120.0,
             tasks_per_worker: int = 250, env: dict[str, str] | None = None,
             memory_limit_mb: int | None = None) -> TaskPool:
        ray = connect(self.address)
        settings = _Settings(float(task_timeout), int(tasks_per_worker),
                             memory_limit_from_env(memory_limit_mb),
                             tuple(sorted((env or {}).items())), __version__)
        return RayPool(ray, settings, self.max_retries)


def get_executor(kind: str = "local", address: str | None = None) -> Executor:
    """The executor named `kind` ("local" or "ray"; `address` is Ray's)."""
    if kind == "local":
        return LOCAL
    if kind == "ray":
        _ray_module()  # a missing Ray is told before anything is written
        return RayExecutor(address or None)
    raise UserError(f"unknown executor {kind!r}; choose from {', '.join(EXECUTORS)}")


def resolve(executor: Executor | str | None) -> Executor:
    """An executor from an executor, a name, or None (local)."""
    if executor is None:
        return LOCAL
    if isinstance(executor, str):
        return get_executor(executor)
    return executor


def connect(address: str | None) -> Any:
    """The `ray` module, connected: to the cluster this process already joined, else to
    `address` (None: `RAY_ADDRESS`, else one `ray start` began on this machine, else a new
    Ray instance on this machine)."""
    ray = _ray_module()
    if not ray.is_initialized():
        try:
            ray.init(address=address or os.environ.get("RAY_ADDRESS") or None,
                     include_dashboard=False, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            where = address or os.environ.get("RAY_ADDRESS") or "a new local instance"
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise UserError(f"cannot connect to Ray at {where}: {first}") from None
    return ray


def _ray_module() -> Any:
    try:
        import ray
    except ImportError:
        raise UserError(RAY_INSTALL_HINT) from None
    return ray


@dataclass(frozen=True)
class _Settings:
    """What a node's `KicadPool` is made with; travels with every task."""

    task_timeout: float
    tasks_per_worker: int
    memory_limit_mb: int
    env: tuple[tuple[str, str], ...]
    version: str  # the driver's pcbdata: a node with another one refuses the task


class RayPool:
    """`KicadPool`'s interface over a Ray cluster: `map` submits Ray tasks of one or a few
    argument tuples each (`batch_size`; at most `IN_FLIGHT_PER_CPU` Ray tasks per cluster CPU
    at a time) and yields `Outcome`s as they finish. `workers` is the cluster's CPU count when
    the pool starts."""

    def __init__(self, ray: Any, settings: _Settings, max_retries: int = MAX_RETRIES):
        self._ray = ray
        self._settings = settings
        self._remote = ray.remote(run_batch).options(num_cpus=1, max_retries=max_retries,
                                                    retry_exceptions=False)
        self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self.memory_limit_mb = settings.memory_limit_mb

    @property
    def task_timeout(self) -> float:
        return self._settings.task_timeout

    @task_timeout.setter
    def task_timeout(self, seconds: float) -> None:
        self._settings = _replace(self._settings, task_timeout=float(seconds))

    def __enter__(self) -> RayPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Nothing to stop: the nodes' workers end with their Ray worker processes."""

    def batch_size(self, remaining: int) -> int:
        """Tasks per Ray task: up to `MAX_BATCH` while there is work for `BATCH_ROUNDS`
        rounds of the whole cluster, then single tasks, so the end of a run stays balanced.
        A Ray task costs the driver about 1 ms of CPU (docs/ray.md), a scored D2 rollout
        about 30 ms of a worker: unbatched, one driver would keep only ~30 CPUs busy."""
        return max(1, min(MAX_BATCH, remaining // (self.workers * BATCH_ROUNDS)))

    def map(self, ref: str, arg_tuples: Iterable[tuple]) -> Iterator[Outcome]:
        todo = [tuple(args) for args in arg_tuples]
        window = self.workers * IN_FLIGHT_PER_CPU
        running: dict[Any, list[int]] = {}
        position = 0
        try:
            while position < len(todo) or running:
                while position < len(todo) and len(running) < window:
                    size = self.batch_size(len(todo) - position)
                    batch = list(range(position, position + size))
                    position += size
                    yield from self._submit(ref, todo, batch, running)
                if running:
                    yield from self._collect(running)
        finally:  # a caller that stops early: what is still running is cancelled
            for object_ref in running:
                self._ray.cancel(object_ref, force=False)

    def _submit(self, ref: str, todo: list[tuple], batch: list[int],
                running: dict) -> Iterator[Outcome]:
        """Submits one Ray task for `batch`; a batch that cannot be sent (arguments that do
        not pickle, say) is sent task by task, and what still fails is a failed outcome, as
        in `KicadPool`."""
        try:
            running[self._remote.remote(ref, [todo[i] for i in batch], self._settings)] = batch
            return
        except Exception as exc:  # noqa: BLE001 - reported like a pool's unrunnable task
            if len(batch) == 1:
                yield Outcome(batch[0], False, None, f"task not run: {type(exc).__name__}: {exc}")
                return
        for index in batch:
            yield from self._submit(ref, todo, [index], running)

    def _collect(self, running: dict) -> Iterator[Outcome]:
        ready, rest = self._ray.wait(list(running), num_returns=1)
        if rest:  # everything else already finished comes in the same round
            more, _ = self._ray.wait(rest, num_returns=len(rest), timeout=0)
            ready += more
        for object_ref in ready:
            batch = running.pop(object_ref)
            try:
                results = self._ray.get(object_ref)
            except Exception as exc:  # noqa: BLE001 - Ray gave up (retries exhausted)
                for index in batch:
                    yield Outcome(index, False, None, _ray_error(exc))
                continue
            for index, (ok, value, error, seconds) in zip(batch, results, strict=True):
                yield Outcome(index, ok, value if ok else None, "" if ok else error, seconds)

    def call(self, ref: str, *args) -> Any:
        [outcome] = list(self.map(ref, [args]))
        if not outcome.ok:
            raise KicadError(outcome.error)
        return outcome.value


def _replace(settings: _Settings, **changes) -> _Settings:
    import dataclasses

    return dataclasses.replace(settings, **changes)


def _ray_error(exc: BaseException) -> str:
    text = str(exc).strip()
    first = text.splitlines()[0] if text else ""
    return f"ray: {type(exc).__name__}: {first}" if first else f"ray: {type(exc).__name__}"


# --- on the nodes -------------------------------------------------------------------------

_NODE: dict[str, Any] = {}  # this Ray worker process's KicadPool and the settings it has


def node_pool(settings: _Settings) -> KicadPool:
    """This Ray worker process's one-worker `KicadPool`, made again when settings change."""
    if _NODE.get("settings") != settings:
        if "pool" in _NODE:
            _NODE.pop("pool").close()
        _NODE["pool"] = KicadPool(workers=1, task_timeout=settings.task_timeout,
                                  tasks_per_worker=settings.tasks_per_worker,
                                  env=dict(settings.env),
                                  memory_limit_mb=settings.memory_limit_mb)
        _NODE["settings"] = settings
    return _NODE["pool"]


def run_batch(ref: str, batch: list[tuple],
              settings: _Settings) -> list[tuple[bool, Any, str, float]]:
    """One Ray task: runs `ref(*args)` for each argument tuple of `batch`, one after the
    other, in this node's KiCad worker (each under the time and memory limits); (ok, value,
    error, seconds) of each, in order, as in an `Outcome`."""
    if settings.version != __version__:
        error = (f"this node runs pcbdata {__version__}, the driver {settings.version}: "
                 f"set every node up from the same checkout")
        return [(False, None, error, 0.0)] * len(batch)
    outcomes = sorted(node_pool(settings).map(ref, batch), key=lambda o: o.index)
    return [(o.ok, o.value, o.error, o.seconds) for o in outcomes]

"""Scoring of routed boards against instances: one board (`score`) or many (`Evaluator`).

KiCad runs in engine worker processes (`pcbdata.kicad.pool.KicadPool`); this module only
moves files and plain data, and computes the metrics with `pcbdata.evaluator.metrics`.
"""
from __future__ import annotations

import hashlib
from collections.abc import Iterable, Iterator
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_file
from pcbdata.core.sexpr_text import cut_problem
from pcbdata.core.tree import BOARD_FILE, INSTANCE_FILES, PROJECT_FILE
from pcbdata.evaluator.integrity import rollout_problems
from pcbdata.evaluator.metrics import DEFAULT_WEIGHTS, Weights, raw_counts, rollout_metrics
from pcbdata.executors import Executor, TaskPool, resolve

#: Bump when any metric, bucket or the integrity check changes: cached scores are keyed by it.
#: 2.0.0: copper transplanted onto the instance's board; evaluation and strict counts.
#: 3.0.0: Pot., f and Phi by the strict count; WL geometric (arcs from their three points);
#: copper off the board or on non-copper layers, and oversized files, make a rollout invalid;
#: a board with no valid rollout counts Pot. 0; reports name the set they scored.
#: 3.1.0: U (and f's unconnected items) from the pad clusters where KiCad's DRC list of
#: unconnected items stops (499): only boards with more missing connections score otherwise.
EVALUATOR_VERSION = "3.1.0"
MEASURE = "pcbdata.kicad.scoring:measure"
SCORE = "pcbdata.evaluator.scorer:score_task"


def instance_dir(instance: str | Path) -> Path:
    """An instance is a board directory (`board.kicad_pcb` + `board.kicad_pro`), or the path of
    its `board.kicad_pcb`."""
    path = Path(instance)
    if path.is_file():
        path = path.parent
    if not (path / BOARD_FILE).is_file() or not (path / PROJECT_FILE).is_file():
        raise UserError(f"{instance}: not an instance directory (needs board.kicad_pcb and "
                        f"board.kicad_pro)")
    return path


def instance_hash(directory: str | Path) -> str:
    """Hash of the instance's files (board, project, custom rules)."""
    digest = hashlib.sha256()
    for name in INSTANCE_FILES:
        path = Path(directory) / name
        digest.update(name.encode() + b"\0")
        digest.update(sha256_file(path).encode() if path.is_file() else b"-")
    return digest.hexdigest()


#: A submitted board may be this many times the size of the largest instance board scored with
#: it (and at least `MIN_SIZE_LIMIT`): copper for every net fits many times over, and KiCad is
#: never handed a huge file.
SIZE_FACTOR = 10
MIN_SIZE_LIMIT = 1 << 20


def size_limit(directories: Iterable[Path]) -> int:
    """The largest submitted file accepted with these instances (bytes)."""
    largest = max((Path(d) / BOARD_FILE).stat().st_size for d in directories)
    return max(MIN_SIZE_LIMIT, SIZE_FACTOR * largest)


def oversize(path: str | Path, max_bytes: int) -> str | None:
    """Why a submitted file is refused unread for its size (above `max_bytes`), or None."""
    path = Path(path)
    size = path.stat().st_size if path.is_file() else 0
    if size <= max_bytes:
        return None
    return (f"file of {size} bytes is above the limit of {max_bytes} bytes ({SIZE_FACTOR} times "
            f"the largest instance board, at least {MIN_SIZE_LIMIT}), not loaded")


#: Byte-order marks KiCad's loader refuses (it finds no board format in the file); CR, LF and
#: CRLF line ends all load.
_BYTE_ORDER_MARKS = ((b"\xef\xbb\xbf", "UTF-8"), (b"\xff\xfe", "UTF-16"),
                     (b"\xfe\xff", "UTF-16"))


def precheck(path: str | Path) -> str | None:
    """A reason why `path` cannot be a `.kicad_pcb` file, found without KiCad; None if it may be."""
    path = Path(path)
    if not path.is_file():
        return "missing file"
    if path.stat().st_size == 0:
        return "empty file"
    with open(path, "rb") as handle:
        head = handle.read(4096)
    for mark, name in _BYTE_ORDER_MARKS:
        if head.startswith(mark):
            return (f"starts with a {name} byte-order mark, which KiCad 9.0.8 does not load "
                    f"(save it as UTF-8 without one; CRLF line ends are fine)")
    if b"\0" in head:
        return "not a .kicad_pcb file (binary data)"
    if not head.lstrip().startswith(b"(kicad_pcb"):
        return "not a .kicad_pcb file (does not start with '(kicad_pcb')"
    return cut_problem(path.read_bytes())  # KiCad's parser can hang on a cut file


#: The metric fields of a record (`metrics.rollout_metrics`); a rollout that is not scored has
#: them empty (CP 0, Rout. 0).
SCORE_FIELDS = ("cp", "cp_strict", "pot", "pot_evaluation", "rout", "drv", "drv_strict",
                "unconnected", "wl", "via", "penalty", "penalty_evaluation", "phi",
                "phi_evaluation", "phi_bare", "phi_bare_evaluation", "net_count", "drv_by_type",
                "drv_strict_by_type")
#: Why a rollout is not scored: its file is not a board KiCad loads, or it is a changed board.
FAILED_STATUSES = ("parse_fail", "invalid")


def failed_record(status: str, reason: str) -> dict:
    record: dict = {field: None for field in SCORE_FIELDS}
    record.update(cp=0, cp_strict=0, rout=0.0, drv_by_type={}, drv_strict_by_type={})
    return {"status": status, "reason": reason, "raw": None, **record}


def complete(stored: dict, weights: Weights = DEFAULT_WEIGHTS) -> dict:
    """A full record from its stored part (status, reason, raw counts, ...): every derived
    figure is computed again from the raw counts, never read."""
    if stored["status"] != "ok":
        return {**stored, **failed_record(stored["status"], stored["reason"])}
    return {**stored, **rollout_metrics(stored["raw"], weights)}


def judge(bare: dict, routed: dict | None, error: str = "",
          weights: Weights = DEFAULT_WEIGHTS) -> dict:
    """The record of one rollout from the measurements of its instance (`bare`) and of the
    routed board (`routed`, None when the engine failed with `error`)."""
    if routed is None:
        return failed_record("parse_fail", f"engine failure: {error}")
    if not routed.get("loaded"):
        return failed_record("parse_fail", routed.get("reason", "KiCad could not load the board"))
    problems = rollout_problems(bare, routed)
    if problems:
        return failed_record("invalid", "; ".join(problems))
    return complete({"status": "ok", "reason": "", "raw": raw_counts(bare, routed)}, weights)


def score_task(routed: str, directory: str, bare: dict, weights: Weights) -> dict:
    """Worker task: measures a routed board in KiCad and judges it against its instance's
    measurements (`bare`). Judging (integrity, metrics) in the workers keeps it off the
    process that hands out the tasks, which is the bottleneck of a large run (docs/ray.md)."""
    from pcbdata.kicad.scoring import measure

    return judge(bare, measure(routed, directory), weights=weights)


class Evaluator:
    """Scores routed boards with a pool of KiCad workers (`pool`, else one of `executor`,
    default this machine's); reuse one for many calls.

    >>> with Evaluator(workers=2) as ev:
    ...     record = ev.score("set/d2/test/d2-test-00000", "runs/d2-test-00000/0.kicad_pcb")
    """

    def __init__(self, workers: int = 1, weights: Weights = DEFAULT_WEIGHTS,
                 pool: TaskPool | None = None, task_timeout: float = 300.0,
                 executor: Executor | str | None = None):
        self.weights = weights
        self._own_pool = pool is None
        self.pool = pool or resolve(executor).pool(workers=workers, task_timeout=task_timeout)
        self._bare: dict[str, dict] = {}

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._own_pool:
            self.pool.close()

    def bare_measurements(self, directories: Iterable[Path]) -> dict[str, dict]:
        """Measurements of the instances' own boards, keyed by instance hash (memoised)."""
        return self._measure_bare({Path(d): instance_hash(d) for d in directories})

    def _measure_bare(self, hashes: dict[Path, str]) -> dict[str, dict]:
        """`bare_measurements` of instances whose hashes are known (directory -> hash)."""
        todo = {}
        for directory, key in hashes.items():
            if key not in self._bare and key not in todo:
                todo[key] = directory
        keys = list(todo)
        jobs = [(str(todo[k] / BOARD_FILE), str(todo[k])) for k in keys]
        for outcome in self.pool.map(MEASURE, jobs):
            directory = todo[keys[outcome.index]]
            if not outcome.ok or not outcome.value.get("loaded"):
                reason = outcome.error if not outcome.ok else outcome.value.get("reason")
                raise UserError(f"{directory}: the instance itself cannot be measured ({reason})")
            self._bare[keys[outcome.index]] = outcome.value
        return self._bare

    def score_many(self, pairs: list[tuple[Path, Path]]) -> Iterator[tuple[int, dict]]:
        """Yields (index, record) for each (instance directory, routed file) pair, as scored."""
        pairs = [(instance_dir(i), Path(r)) for i, r in pairs]
        hashes = {d: instance_hash(d) for d in dict.fromkeys(d for d, _ in pairs)}  # once each
        bare = self._measure_bare(hashes)
        keys = [hashes[d] for d, _ in pairs]
        max_bytes = size_limit(hashes)
        jobs, job_index = [], []
        for index, (directory, routed) in enumerate(pairs):
            reason, status = oversize(routed, max_bytes), "invalid"
            if reason is None:
                reason, status = precheck(routed), "parse_fail"
            if reason is not None:
                yield index, failed_record(status, reason)
                continue
            jobs.append((str(routed), str(directory), bare[keys[index]], self.weights))
            job_index.append(index)
        for outcome in self.pool.map(SCORE, jobs):
            index = job_index[outcome.index]
            record = outcome.value if outcome.ok else judge(bare[keys[index]], None,
                                                            outcome.error, self.weights)
            record["score_seconds"] = outcome.seconds
            yield index, record

    def score(self, instance: str | Path, routed: str | Path) -> dict:
        """The record of one routed board: status (ok / invalid / parse_fail), reason, and
        `raw` (the counts every figure derives from) and `SCORE_FIELDS`: cp, drv, drv_by_type
        under the evaluation count and cp_strict (CP+), drv_strict (DRV+), drv_strict_by_type
        under the strict count; pot, penalty, phi, phi_bare under the strict count with
        `_evaluation` twins; rout, unconnected, wl, via, net_count."""
        return next(iter(self.score_many([(Path(instance), Path(routed))])))[1]


def score(instance: str | Path, routed: str | Path, weights: Weights = DEFAULT_WEIGHTS,
          pool: TaskPool | None = None) -> dict:
    """Scores one routed `.kicad_pcb` against an instance directory (see `Evaluator.score`).

    Starts a KiCad worker for the call unless `pool` is given; for many calls keep an
    `Evaluator` (or a pool) open instead.
    """
    with Evaluator(weights=weights, pool=pool) as evaluator:
        return evaluator.score(instance, routed)

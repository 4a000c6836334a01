"""Builds synthetic board sets (D1, D2, D2R) into a folder: boards, arrays, KiCad checks,
manifest, and (opt-in) router-found reference routings (`reference_routing`).

Resumable: board folders are written atomically and skipped when their bytes are already
right; KiCad checks are logged per board hash in `DIR/.pcbdata/checks.jsonl`; the manifest is
written last, so an interrupted build is just run again. With reference routing the manifest
is written once the boards pass their checks (the routing environment reads the set's config
from it) and again once the references are routed and checked.
"""
from __future__ import annotations

import json
import os
import shutil
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from pcbdata import __version__
from pcbdata.build import reference as reference_routing
from pcbdata.build.progress import Progress
from pcbdata.build.reference import ReferencePlan
from pcbdata.core.errors import EngineError, GenerationError, UserError, ValidationError
from pcbdata.core.fsutil import (
    PROBE_PREFIX,
    folder_lock,
    remove_stale_temps,
    write_atomic,
    write_dir_atomic,
)
from pcbdata.core.hashing import sha256_bytes
from pcbdata.core.tree import (
    BOARD_FILE,
    MANIFEST_NAME,
    PROJECT_FILE,
    REFERENCE_FILE,
    RULES_FILE,
    SYNTHETIC_STATE_DIR,
    arrays_name,
    arrays_path,
    board_relpath,
    check_log_path,
    folder_holds,
    split_dir,
)
from pcbdata.executors import Executor, TaskPool, resolve
from pcbdata.generators.base import Generator, SplitArrays
from pcbdata.generators.families import family
from pcbdata.kicad.drc_report import UNCONNECTED_LIST_CAP, DrcReport
from pcbdata.model.kicad_writer import board_files
from pcbdata.model.manifest import FORMAT, merge_configs, write_manifest

STATE_DIR = SYNTHETIC_STATE_DIR
_CHUNK = 128
GENERATE = "pcbdata.build.synthetic:generate_chunk"
_GENERATE_TIMEOUT = 600.0  # seconds per chunk of _CHUNK boards (about 0.2 s when idle)


@dataclass
class SplitJob:
    """One split of one config: which boards to make and which of them to check in KiCad."""

    config: str
    split: str
    count: int
    generator: Generator  # picklable: runs in worker processes
    check_indices: list[int]
    reference: bool = False  # route a reference for each board (the build's ReferencePlan)


@dataclass
class ConfigInfo:
    """A config's entry in the manifest: `extra` holds the family's own fields."""

    family: str
    set_version: str
    seed: int
    parameters: dict
    extra: dict = field(default_factory=dict)


@dataclass
class BuildSummary:
    boards: int = 0
    written: int = 0
    unchanged: int = 0
    checked: int = 0
    check_skipped: int = 0
    failures: list[str] = field(default_factory=list)
    engine_failures: list[tuple[str, str]] = field(default_factory=list)  # (board, reason)
    seconds: float = 0.0
    references: dict[str, int] | None = None  # boards per reference status (None: option off)
    references_kept: int = 0  # of them, results of an earlier run

    def line(self) -> str:
        return (f"{self.boards} boards ({self.written} written, {self.unchanged} unchanged), "
                f"{self.checked} checked in KiCad ({self.check_skipped} already checked), "
                f"{len(self.failures)} failures, {self.seconds:.1f} s{self._reference_line()}")

    def _reference_line(self) -> str:
        if self.references is None:
            return ""
        n = self.references
        return (f"; references: {n['routed']} of {sum(n.values())} boards routed "
                f"({self.references_kept} kept from an earlier run), {n['not_completed']} not "
                f"completed, {n['check_failed']} refused by the KiCad check, "
                f"{n['engine_failure']} engine failures"
                + (" (run again to retry them)" if n["engine_failure"] else ""))


def check_sample(count: int, sample: int | None) -> list[int]:
    """Indices to check in KiCad: all of them (`sample` None) or `sample` evenly spread ones."""
    if sample is None or sample >= count:
        return list(range(count))
    if sample <= 0:
        return []
    return sorted({(k * count) // sample for k in range(sample)})


def generate_chunk(root: str, job: SplitJob, seed: int, indices: list[int]) -> dict:
    """Worker task: `{"entries": [...]}`; `{"user_error": message}` when a generator cannot
    make a board, `{"os_error": [errno, strerror, filename]}` when the output cannot be
    written (a full or read-only disk). The parent raises them again, so the user sees one
    clear line, not an engine failure."""
    try:
        return {"entries": _generate_chunk(root, job, seed, indices)}
    except UserError as exc:
        return {"user_error": str(exc)}
    except OSError as exc:
        return {"os_error": [exc.errno, exc.strerror, exc.filename]}


def _generate_chunk(root: str, job: SplitJob, seed: int, indices: list[int]) -> list[dict]:
    """Generates boards, writes their folders if their bytes differ; returns entries."""
    out = []
    folder = split_dir(root, job.config, job.split)
    arrays = job.generator if isinstance(job.generator, SplitArrays) else None
    for index in indices:
        instance = job.generator.generate(seed, job.split, index)
        files = board_files(instance.board)
        if instance.reference is not None:
            files[REFERENCE_FILE] = board_files(instance.reference)[BOARD_FILE]
        encoded = {name: text.encode("utf-8") for name, text in files.items()}
        board_dir = folder / instance.board_id
        # A router-found reference is added later by this build; an unchanged board keeps it.
        later = (REFERENCE_FILE,) if job.reference and REFERENCE_FILE not in encoded else ()
        written = not folder_holds(board_dir, encoded, later)
        if written:
            write_dir_atomic(board_dir, dict[str, bytes | str](encoded))
        out.append({
            "index": index,
            "board_id": instance.board_id,
            "written": written,
            "files": {name: sha256_bytes(data) for name, data in sorted(encoded.items())},
            "facts": instance.facts(job.generator.routing_layers),
            "missing_connections": instance.board.missing_connections,
            "array_row": arrays.array_row(instance) if arrays is not None else None,
        })
    return out


def check_root(root: str | Path) -> Path:
    """The folder a set may be built into (raises `UserError` otherwise); writes nothing."""
    root = Path(root)
    if root.exists() and not root.is_dir():
        raise UserError(f"{root}: exists and is not a folder")
    if root.is_dir() and any(not p.name.startswith(PROBE_PREFIX) for p in root.iterdir()):
        if not ((root / MANIFEST_NAME).exists() or (root / STATE_DIR).exists()):
            raise UserError(f"{root}: folder is not empty and is not a pcbdata board set; "
                            f"choose an empty or new --out folder")
    return root


@contextmanager
def locked_root(root: str | Path) -> Iterator[Path]:
    """Checks `root`, then holds it for this process (`fsutil.folder_lock`): a second build
    into the same folder waits, so its resume, leftover clean-up and manifest never race this
    one. The CLI holds it across the build and the publication that follows."""
    root = check_root(root)
    with folder_lock(root, "built"):
        yield root


def _prepare_root(root: Path) -> None:
    (root / STATE_DIR).mkdir(parents=True, exist_ok=True)
    remove_stale_temps(root)


class _CheckLog:
    """Boards already checked in KiCad, by relative path and board-file sha256."""

    def __init__(self, root: Path):
        self.path = check_log_path(root)
        self.done: set[tuple[str, str]] = set()
        if self.path.exists():
            for line in self.path.read_text(encoding="utf-8").splitlines():
                try:
                    entry = json.loads(line)
                    self.done.add((entry["path"], entry["sha256"]))
                except (json.JSONDecodeError, KeyError):
                    continue  # a line cut short by a kill; that board is checked again
        self._handle = open(self.path, "a", encoding="utf-8")

    def add(self, rel: str, sha: str) -> None:
        self._handle.write(json.dumps({"path": rel, "sha256": sha}) + "\n")
        self._handle.flush()
        self.done.add((rel, sha))

    def close(self) -> None:
        self._handle.close()


def check_problem(report: DrcReport, expected_unconnected: int) -> str | None:
    """Why a generated board fails its check, or None: only the expected unconnected items
    (of a board with more than KiCad lists, a full list: the check confirms that many)."""
    other = report.counts_by_type(include_unconnected=False)
    unconnected = len([v for v in report.unconnected if v.severity != "excluded"])
    listable = min(expected_unconnected, UNCONNECTED_LIST_CAP)
    if other or unconnected != listable:
        first = next((v for v in report.violations if v.section != "unconnected"), None)
        detail = f"; first: [{first.type}] {first.message} at {first.items[0].description}" \
            if first and first.items else ""
        cap = f", of which KiCad lists at most {UNCONNECTED_LIST_CAP}" \
            if expected_unconnected > UNCONNECTED_LIST_CAP else ""
        return (f"DRC found {other or 'no other violations'} and {unconnected} unconnected "
                f"items (expected {expected_unconnected}{cap}){detail}")
    return None


def build_synthetic(root: str | Path, jobs: list[SplitJob], configs: dict[str, ConfigInfo],
                    workers: int | None = None, log: Callable[[str], None] | None = None,
                    task_timeout: float = 120.0,
                    executor: Executor | str | None = None,
                    reference: ReferencePlan | None = None) -> BuildSummary:
    """Builds `jobs` into `root`; tasks run on `executor` (default: this machine's workers;
    `pcbdata.executors`), with the same bytes whichever runs them. `reference` routes the
    boards of the jobs marked `reference` (`reference_routing`)."""
    with locked_root(root) as folder:
        return _build_locked(folder, jobs, configs, workers, task_timeout, resolve(executor),
                             reference)


def _build_locked(root: Path, jobs: list[SplitJob], configs: dict[str, ConfigInfo],
                  workers: int | None, task_timeout: float, executor: Executor,
                  reference: ReferencePlan | None = None) -> BuildSummary:
    workers = max(1, workers or os.cpu_count() or 1)
    started = time.perf_counter()
    _prepare_root(root)
    summary = BuildSummary()
    entries: dict[tuple[str, str], list[dict]] = {}
    # Generation needs no KiCad but runs in the same exec-started workers: they never
    # re-import the caller's __main__ and die with this process (multiprocessing's would not).
    with executor.pool(workers=workers, task_timeout=_GENERATE_TIMEOUT) as pool:
        for job in jobs:
            seed = configs[job.config].seed
            progress = Progress(f"{job.config}/{job.split} write", job.count)
            chunks = [list(range(i, min(i + _CHUNK, job.count)))
                      for i in range(0, job.count, _CHUNK)]
            results: list[dict] = []
            for outcome in pool.map(GENERATE, [(str(root), job, seed, c) for c in chunks]):
                entries_of_chunk = _chunk_entries(outcome, job, chunks[outcome.index])
                results.extend(entries_of_chunk)
                progress.advance(len(entries_of_chunk))
            results.sort(key=lambda r: r["index"])
            _remove_extra_boards(split_dir(root, job.config, job.split),
                                 {r["board_id"] for r in results})
            entries[(job.config, job.split)] = results
            summary.boards += len(results)
            summary.written += sum(r["written"] for r in results)
            summary.unchanged += sum(not r["written"] for r in results)
            if isinstance(job.generator, SplitArrays):
                data = job.generator.split_arrays([r["board_id"] for r in results],
                                                  [r["array_row"] for r in results])
                write_atomic(arrays_path(root, job.config, job.split), data)
    check_pool = partial(executor.pool, workers=workers, task_timeout=task_timeout)
    if reference is None:
        _check_and_write(root, jobs, configs, entries, summary, check_pool)
    else:
        # A rollout worker keeps one environment (and its KiCad worker) for all its boards.
        route_pool = partial(executor.pool, task_timeout=reference.task_timeout,
                             tasks_per_worker=10**9, memory_limit_mb=0)
        _references(root, jobs, configs, entries, summary, check_pool, reference,
                    route_pool, workers)
    summary.seconds = time.perf_counter() - started
    return summary


def _check_and_write(root: Path, jobs: list[SplitJob], configs: dict[str, ConfigInfo], entries,
                     summary: BuildSummary, check_pool: Callable[[], TaskPool],
                     reference: ReferencePlan | None = None) -> None:
    """KiCad checks of what is not checked yet, then the manifest (none if a check failed)."""
    _check_in_kicad(root, jobs, configs, entries, summary, check_pool, reference)
    _raise_check_failures(summary)
    _write_manifest(root, jobs, configs, entries, reference)


def _references(root: Path, jobs: list[SplitJob], configs: dict[str, ConfigInfo], entries,
                summary: BuildSummary, check_pool: Callable[[], TaskPool],
                reference: ReferencePlan, route_pool: Callable[[int], TaskPool],
                workers: int) -> None:
    """The build with reference routing: results of an earlier run restored, boards checked and
    the manifest written (the environment reads the set's config from it), the other boards
    routed (a rollout worker each: `route_pool`), the new references checked, the manifest
    written again."""
    boards = [(job.config, job.split, entry) for job in jobs if job.reference
              for entry in entries[(job.config, job.split)]]
    to_route = reference_routing.restore(root, reference, boards)
    summary.references_kept = sum("reference_routing" in entry for *_, entry in boards)
    _check_and_write(root, jobs, configs, entries, summary, check_pool, reference)
    if to_route:
        reference_routing.route(root, reference, to_route, route_pool, workers)
        skipped = summary.check_skipped  # the second pass skips what the first one counted
        _check_and_write(root, jobs, configs, entries, summary, check_pool, reference)
        summary.check_skipped = skipped
    summary.references = reference_routing.counts([entry for *_, entry in boards])


def _raise_check_failures(summary: BuildSummary) -> None:
    if summary.engine_failures:
        board, reason = summary.engine_failures[0]
        more = len(summary.engine_failures) - 1
        raise EngineError(reason + (f" (and {more} more boards)" if more else ""), board=board)
    if summary.failures:
        raise ValidationError(
            f"{len(summary.failures)} board(s) failed the KiCad check; the set is left "
            f"without a manifest. First failures:\n  " + "\n  ".join(summary.failures[:5]))


def _chunk_entries(outcome, job: SplitJob, chunk: list[int]) -> list[dict]:
    if outcome.ok and "user_error" in outcome.value:
        raise GenerationError(outcome.value["user_error"])
    if outcome.ok and "os_error" in outcome.value:
        raise OSError(*outcome.value["os_error"])
    if not outcome.ok:
        raise EngineError(f"generating {job.config}/{job.split} boards {chunk[0]}-{chunk[-1]} "
                          f"failed: {outcome.error}")
    return outcome.value["entries"]


def _keep_other_splits(root: Path, built: dict[str, dict]) -> None:
    """Building some splits of a config keeps the splits an earlier build of the same
    parameters put in the manifest (and on disk)."""
    if not (root / MANIFEST_NAME).exists():
        return
    from pcbdata.model.manifest import read_manifest

    old_configs = read_manifest(root).get("configs", {})
    for name, config in built.items():
        old = old_configs.get(name)
        same = old and all(old.get(k) == config.get(k)
                           for k in ("family", "set_version", "seed", "parameters"))
        if same:
            for split, data in old["splits"].items():
                config["splits"].setdefault(split, data)
        config["splits"] = dict(sorted(config["splits"].items()))


def _remove_extra_boards(split_dir: Path, keep: set[str]) -> None:
    """A rebuild with fewer boards must not leave boards of an earlier build behind."""
    if split_dir.is_dir():
        for child in split_dir.iterdir():
            if child.is_dir() and child.name.startswith("board_") and child.name not in keep:
                shutil.rmtree(child)


def _check_in_kicad(root: Path, jobs: list[SplitJob], configs: dict[str, ConfigInfo],
                    entries, summary: BuildSummary, engine: Callable[[], TaskPool],
                    reference: ReferencePlan | None = None) -> None:
    """Checks the boards not checked yet, in a pool made by `engine`. A router-found reference
    that fails is dropped with the reason (`reference_routing.refuse`), not a failed build."""
    checks = _CheckLog(root)
    todo = []  # (relative board path, sha, expected unconnected, job, entry)
    for job in jobs:
        by_index = {r["index"]: r for r in entries[(job.config, job.split)]}
        for index in job.check_indices:
            entry = by_index[index]
            targets = [(BOARD_FILE, entry["missing_connections"])]
            if REFERENCE_FILE in entry["files"]:
                targets.append((REFERENCE_FILE, 0))  # a reference routing connects everything
            for name, expected in targets:
                rel = board_relpath(job.config, job.split, entry["board_id"], name)
                if (rel, entry["files"][name]) in checks.done:
                    summary.check_skipped += 1
                else:
                    todo.append((rel, entry["files"][name], expected, job, entry))
    if not todo:
        checks.close()
        return
    progress = Progress("KiCad check", len(todo))
    try:
        with engine() as pool:
            args = [_drc_args(root, rel) for rel, *_ in todo]
            for outcome in pool.map("pcbdata.kicad.basics:drc", args):
                rel, sha, expected, job, entry = todo[outcome.index]
                progress.advance()
                if not outcome.ok:
                    summary.engine_failures.append((rel, outcome.error))
                    continue
                problem = check_problem(DrcReport.from_dict(outcome.value), expected)
                if problem and reference is not None and rel.endswith("/" + REFERENCE_FILE) \
                        and "reference_routing" in entry:
                    reference_routing.refuse(root, reference, (job.config, job.split, entry),
                                             problem)
                elif problem:
                    params = json.dumps(configs[job.config].parameters, sort_keys=True)
                    summary.failures.append(f"{rel}: {problem} (parameters {params})")
                else:
                    checks.add(rel, sha)
                    summary.checked += 1
    finally:
        checks.close()


def _drc_args(root: Path, rel: str) -> tuple:
    """Every file of a board folder is checked under the folder's own project and rules."""
    path = root / rel
    project = path.parent / PROJECT_FILE
    rules = path.parent / RULES_FILE
    return (str(path), str(project), str(rules) if rules.exists() else None)


def _kicad_version(required: bool) -> str:
    """KiCad's version for the manifest. A build that checked nothing (`--no-check`) needs no
    KiCad: without one it records "unknown" instead of failing."""
    from pcbdata.kicad import KicadError, kicad_version

    try:
        return kicad_version()
    except KicadError as exc:
        if required:
            raise EngineError(f"cannot ask KiCad its version: {exc}") from None
        return "unknown"


def _write_manifest(root: Path, jobs: list[SplitJob], configs: dict[str, ConfigInfo],
                    entries, reference: ReferencePlan | None = None) -> None:
    built: dict[str, dict] = {}
    for job in jobs:
        info = configs[job.config]
        config = built.setdefault(job.config, {
            "family": info.family, "set_version": info.set_version, "seed": info.seed,
            "seed_scheme": family(info.family).seed_scheme, "parameters": info.parameters,
            **info.extra,
            "splits": {},
        })
        boards = {}
        for entry in sorted(entries[(job.config, job.split)], key=lambda e: e["board_id"]):
            origin = {k: entry[k] for k in ("reference_routing",) if k in entry}
            boards[entry["board_id"]] = {"files": entry["files"], **entry["facts"], **origin}
        split = {"count": job.count, "kicad_checked": len(job.check_indices), "boards": boards}
        if job.reference and reference is not None:
            split["reference_routing"] = reference_routing.split_record(
                reference, entries[(job.config, job.split)])
        if isinstance(job.generator, SplitArrays):
            npz = arrays_path(root, job.config, job.split)
            split["arrays"] = {arrays_name(job.split): sha256_bytes(npz.read_bytes())}
        config["splits"][job.split] = split
    _keep_other_splits(root, built)
    checked = any(job.check_indices for job in jobs)
    base = {"format": FORMAT, "package_version": __version__,
            "kicad_version": _kicad_version(required=checked)}
    manifest = merge_configs(root, base, built)
    write_manifest(root, manifest)

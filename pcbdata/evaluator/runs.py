"""Scoring a whole submission (`pcbdata eval`): the @k protocol, resumable caching, reports.

Layout of a submission (RUNS): `<board_id>/<rollout>.kicad_pcb`, optionally with
`<rollout>.json` holding the method's wall time (`time_s`, or `time` / `seconds`) and any other
fields; a `<rollout>.json` without its board is a rollout that produced no board (Parse-fail,
its time still counts). Rollouts are ordered by name (natural order: 2 before 10); the first k
are scored. A board with no rollout at all gets one Parse-fail rollout named `missing`.
"""
from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import re
import sys
from pathlib import Path

from pcbdata import __version__
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import folder_lock, write_atomic
from pcbdata.core.hashing import sha256_file
from pcbdata.core.tree import REFERENCE_FILE, list_instances
from pcbdata.evaluator.accounting import llm_totals
from pcbdata.evaluator.metrics import DEFAULT_WEIGHTS, Weights, convention_of
from pcbdata.evaluator.protocol import board_row, summarize
from pcbdata.evaluator.results import RESULTS_FILE, results_text
from pcbdata.evaluator.results import build as build_results
from pcbdata.evaluator.scorer import EVALUATOR_VERSION, Evaluator, complete, instance_hash
from pcbdata.executors import Executor
from pcbdata.kicad.pool import is_limit_error, memory_limit_from_env
from pcbdata.sets.identity import mark, refuse_unverified, set_identity

TIME_KEYS = ("time_s", "time", "seconds", "wall_time_s")
ROLLOUT_COLUMNS = ["board_id", "rollout", "index", "status", "reason", "cp", "pot", "rout", "drv",
                   "unconnected", "wl", "via", "penalty", "phi", "phi_bare", "net_count", "time",
                   "drv_by_type", "cp_strict", "drv_strict", "drv_strict_by_type",
                   "pot_evaluation", "penalty_evaluation", "phi_evaluation",
                   "phi_bare_evaluation", "sha256"]
BOARD_COLUMNS = ["board_id", "n_rollouts", "n_ok", "n_invalid", "n_parse_fail", "parse_fail",
                 "best_rollout", "cp", "pot", "rout", "drv", "unconnected", "wl", "via", "time",
                 "cp_strict", "drv_strict", "pot_evaluation"]
CACHE_NAME = "scores.jsonl"
KICAD_VERSION = "pcbdata.kicad.basics:kicad_version"
#: What a cache line keeps of a record: every figure is derived again from `raw` on reading.
STORED_FIELDS = ("status", "reason", "raw", "sha256", "score_seconds")


def natural_key(name: str) -> list:
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name)]


# A sidecar is a few fields; a bigger one is not read (it would be read whole into memory).
MAX_SIDECAR_BYTES = 1 << 20
# A wall time beyond this (about 11.6 days per rollout) is a unit mistake or garbage.
MAX_TIME_S = 1e6


def rollout_time(board_file: Path) -> float | None:
    """The method's wall time of a rollout from its sidecar, or None (none, or not valid)."""
    return read_rollout_time(board_file)[0]


def read_rollout_time(board_file: Path) -> tuple[float | None, str]:
    """(time, problem) of a rollout's `<rollout>.json`: the time is None when there is no
    sidecar or no time key, and also when the sidecar or its time is not valid, which
    `problem` then says (a valid time: a number from 0 to MAX_TIME_S, not a boolean)."""
    sidecar = board_file.with_suffix(".json")
    if not sidecar.is_file():
        return None, ""
    data, problem = _read_sidecar(sidecar)
    if problem:
        return None, problem
    if not isinstance(data, dict):
        return None, f"{sidecar.name}: not a JSON object"
    key = next((k for k in TIME_KEYS if data.get(k) is not None), None)  # null: no time
    if key is None:
        return None, ""
    value = data[key]
    valid = (isinstance(value, (int, float)) and not isinstance(value, bool)
             and math.isfinite(value) and 0 <= value <= MAX_TIME_S)
    if not valid:
        is_scalar = isinstance(value, (bool, int, float, str))
        shown = repr(value)[:40] if is_scalar else type(value).__name__
        return None, (f"{sidecar.name}: invalid {key} {shown} (expected a number of seconds "
                      f"from 0 to {MAX_TIME_S:g})")
    return float(value), ""


def _read_sidecar(sidecar: Path) -> tuple[object, str]:
    try:
        if sidecar.stat().st_size > MAX_SIDECAR_BYTES:
            return None, f"{sidecar.name}: larger than {MAX_SIDECAR_BYTES} bytes, not read"
        return json.loads(sidecar.read_bytes().decode("utf-8")), ""
    except OSError as exc:
        return None, f"{sidecar.name}: unreadable ({exc.strerror})"
    except UnicodeDecodeError:
        return None, f"{sidecar.name}: not UTF-8 text"
    except ValueError as exc:
        return None, f"{sidecar.name}: not valid JSON ({str(exc).splitlines()[0][:80]})"
    except RecursionError:
        return None, f"{sidecar.name}: JSON nested too deeply to read"


def list_rollouts(runs: Path, board_id: str, k: int) -> list[tuple[str, Path]]:
    folder = runs / board_id
    if not folder.is_dir():
        return []
    stems = {p.stem for p in folder.glob("*.kicad_pcb")} | {p.stem for p in folder.glob("*.json")}
    return [(stem, folder / f"{stem}.kicad_pcb") for stem in sorted(stems, key=natural_key)[:k]]


def runs_warnings(runs: Path, split_ids: list[str], scored_ids: list[str], k: int) -> dict:
    """What in RUNS is not scored, by kind: entries that are not a board of the split, board
    entries that are not folders, files that are not rollouts, and rollouts beyond the first
    k per board (the @k protocol). Boards of the split left out by `limit` are not listed."""
    known = set(split_ids)
    out = {"not_in_split": sorted(p.name for p in runs.iterdir() if p.name not in known),
           "not_a_folder": [], "not_a_rollout": [], "beyond_k": []}
    for board_id in scored_ids:
        folder = runs / board_id
        if not folder.is_dir():
            if folder.exists() or folder.is_symlink():
                out["not_a_folder"].append(board_id)
            continue
        out["not_a_rollout"] += sorted(f"{board_id}/{p.name}" for p in folder.iterdir()
                                       if p.suffix not in (".kicad_pcb", ".json"))
        stems = ({p.stem for p in folder.glob("*.kicad_pcb")}
                 | {p.stem for p in folder.glob("*.json")})
        out["beyond_k"] += [f"{board_id}/{stem}" for stem in sorted(stems, key=natural_key)[k:]]
    return out


def cache_key(instance_key: str, routed_hash: str, weights: Weights) -> str:
    text = json.dumps([EVALUATOR_VERSION, instance_key, routed_hash, weights.as_dict()],
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def limit_cache_key(key: str, limits: tuple[float, int]) -> str:
    """Cache key of a rollout that hit the engine's time or memory limit (seconds, MiB): the
    same file is not run again under the same limits, and is under other ones."""
    text = json.dumps([key, "limits", float(limits[0]), int(limits[1])])
    return hashlib.sha256(text.encode()).hexdigest()


def record_digest(key: str, stored: dict) -> str:
    """The digest a cache line carries: an edited record no longer matches it."""
    text = json.dumps([EVALUATOR_VERSION, key, stored], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def cache_line(key: str, record: dict) -> str:
    stored = {field: record.get(field) for field in STORED_FIELDS}
    return json.dumps({"key": key, "record": stored, "digest": record_digest(key, stored)},
                      sort_keys=True) + "\n"


def load_cache(path: Path) -> tuple[dict[str, dict], int]:
    """(stored records by key, number of lines whose record does not match its digest). Those
    are left out, so their rollouts are scored again; a line cut by an interrupted run too."""
    cache: dict[str, dict] = {}
    tampered = 0
    if path.is_file():
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                entry = json.loads(line)
                key, stored, digest = entry["key"], entry["record"], entry["digest"]
                _ = stored["status"], stored["reason"], stored["raw"]
            except (ValueError, KeyError, TypeError):
                continue
            if digest != record_digest(key, stored):
                tampered += 1
                continue
            cache[key] = stored
    return cache, tampered


def _fmt(value, digits: int = 2) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def markdown_table(summaries: list[tuple[str, dict]]) -> str:
    """The results table in the benchmark paper's shape (one row per method), then the strict
    count's diagnostic columns CP+ and DRV+ (SPEC 4) and the failure rates. A method scored on
    an unverified set, or one that differs from its release, says so in its cell."""
    lines = ["| Method | CP (%) | Pot. | Rout. | DRV | WL (mm) | Via | Time (s) | "
             "CP+ (%) | DRV+ | Parse-fail (%) | Parse-fail @1 (%) | Invalid (%) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, s in summaries:
        pct = lambda v: "-" if v is None else f"{100 * v:.1f}"  # noqa: E731
        lines.append(f"| {name}{mark(s.get('set'))} | {pct(s['cp'])} | {_fmt(s['pot'])} | "
                     f"{_fmt(s['rout'], 3)} | "
                     f"{_fmt(s['drv'])} | {_fmt(s['wl'], 1)} | {_fmt(s['via'])} | "
                     f"{_fmt(s['time'])} | "
                     f"{pct(s.get('cp_strict'))} | {_fmt(s.get('drv_strict'))} | "
                     f"{pct(s['parse_fail'])} | {pct(s['parse_fail_at1'])} | {pct(s['invalid'])} |")
    return "\n".join(lines) + "\n"


def _csv(rows: list[dict], columns: list[str]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({c: (json.dumps(row[c], sort_keys=True) if isinstance(row.get(c), dict)
                             else ("" if row.get(c) is None else row[c])) for c in columns})
    return out.getvalue()


def _check_arguments(k, workers, weights: Weights, task_timeout, limit, name) -> None:
    """The ranges of evaluate_set's arguments (the CLI checks them too, before this)."""
    def integer(value) -> bool:
        return isinstance(value, int) and not isinstance(value, bool)

    if not integer(k) or k < 1:
        raise UserError(f"--k must be an integer >= 1, got {k!r}")
    if not integer(workers) or workers < 1:
        raise UserError(f"--workers must be an integer >= 1, got {workers!r}")
    if limit is not None and (not integer(limit) or limit < 1):
        raise UserError(f"--limit must be an integer >= 1 (or absent: every board), got {limit!r}")
    if isinstance(task_timeout, bool) or not isinstance(task_timeout, (int, float)) \
            or not math.isfinite(task_timeout) or task_timeout <= 0:
        raise UserError(f"--timeout must be a finite number of seconds > 0, got {task_timeout!r}")
    for key, value in weights.as_dict().items():
        if key == "bare_drc":
            if not isinstance(value, bool):
                raise UserError(f"weight bare_drc must be true or false, got {value!r}")
        elif isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value) or value < 0:
            raise UserError(f"weight {key} must be a finite number >= 0, got {value!r}")
    if name is not None and (not name.strip() or any(c in name for c in "|\r\n")):
        raise UserError(f"--name {name!r}: must be non-empty, without '|' or line breaks "
                        f"(it is a cell of the markdown table)")


_SHOWN_WARNINGS = 10


def quoted(name: str) -> str:
    """A name as one line can show it: in JSON quotes when it holds a line break, another
    control character or the separator `;` (a file may be named anything)."""
    if name.isprintable() and ";" not in name:
        return name
    return json.dumps(name)


def _print_warnings(warnings: dict, runs: Path) -> None:
    """One stderr line per kind of RUNS entry that is not scored (all of them are recorded
    in summary.json under `runs_warnings`)."""
    what = {"not_in_split": "entries that are not boards of this split, ignored",
            "not_a_folder": "board entries that are not folders, scored as missing",
            "not_a_rollout": "files that are not rollouts (.kicad_pcb, .json), ignored",
            "beyond_k": "rollouts beyond the first k, not scored",
            "invalid_times": "rollout times not valid, not counted",
            "untimed": "rollouts without a time while others have one: Time averages the rest"}
    for kind, items in warnings.items():
        if not items:
            continue
        names = [f"{quoted(i['board_id'] + '/' + i['rollout'])}: {quoted(i['reason'])}"
                 if isinstance(i, dict) else quoted(i) for i in items]
        shown = "; ".join(names[:_SHOWN_WARNINGS])
        more = f"; ... {len(names) - _SHOWN_WARNINGS} more" if len(names) > _SHOWN_WARNINGS else ""
        print(f"pcbdata eval: warning: {runs}: {what[kind]} ({len(names)}): {shown}{more}; "
              f"summary.json lists them under runs_warnings.{kind}", file=sys.stderr)


Plan = list[tuple[str, str, int, Path, Path]]  # (board_id, rollout, index, instance, board)


def evaluate_set(root: str | Path, config: str, split: str, out: str | Path,
                 runs: str | Path | None = None, k: int = 5, reference: bool = False,
                 workers: int = 1, weights: Weights = DEFAULT_WEIGHTS, name: str | None = None,
                 task_timeout: float = 300.0, progress: bool = True,
                 limit: int | None = None, executor: Executor | str | None = None,
                 use_cache: bool = True, allow_unverified: bool = False) -> dict:
    """Scores a submission (or the reference boards) on one config/split; writes REPORT files
    (`results.json` among them: `pcbdata.evaluator.results`) and returns the summary. Re-runs
    reuse scores cached in `out/scores.jsonl` (time and memory limits hit too, under the same
    limits); a cached record that does not match its digest is scored again, and
    `use_cache=False` scores everything again (the way to trust a REPORT folder someone else
    wrote). `limit` scores only the first N boards of the split (in
    board-id order). A second call on the same `out` waits for the first. The boards are
    scored on `executor` (default: this machine's workers; `pcbdata.executors`; `workers` is
    the local executor's), with the same report whichever scores them. The scored split's
    boards must match the set's manifest unless `allow_unverified` (the report says so)."""
    root, out = Path(root), Path(out)
    _check_arguments(k, workers, weights, task_timeout, limit, name)
    if reference == (runs is not None):
        raise UserError("give either RUNS (--runs) or --reference")
    runs_dir = None if runs is None else Path(runs)
    if runs_dir is not None and not runs_dir.is_dir():
        raise UserError(f"{runs}: no such RUNS directory")
    _check_out(out, root, runs_dir)
    every = list_instances(root, config, split)
    identity = set_identity(root, config, split)
    if not allow_unverified:
        refuse_unverified(identity, root)
    instances = every[:limit] if limit is not None else every
    without: list[str] = []
    if reference:
        instances, without = _with_reference(instances, config, split, limit)
    plan = _plan(instances, runs_dir, k)
    warnings = {} if runs_dir is None else runs_warnings(
        runs_dir, [b for b, _ in every], [b for b, _ in instances], k)
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out, "written"):  # a second eval into REPORT waits: reports never mix
        records, cache_stats, kicad_version = _score_plan(
            plan, instances, out, weights, workers, task_timeout, progress, executor, use_cache)
        rollout_rows = _rollout_rows(plan, records, reference, warnings)
        if warnings and progress and runs_dir is not None:
            _print_warnings(warnings, runs_dir)
        if without and progress:
            print(f"pcbdata eval: {_without_line(len(instances), without)} "
                  f"({', '.join(without[:_SHOWN_WARNINGS])}"
                  f"{', ...' if len(without) > _SHOWN_WARNINGS else ''})", file=sys.stderr)
        by_board: dict[str, list[dict]] = {}
        for row in rollout_rows:
            by_board.setdefault(row["board_id"], []).append(row)
        board_rows = [board_row(board_id, by_board[board_id]) for board_id, _ in instances]
        summary = summarize(board_rows, rollout_rows, 1 if reference else k)
        summary.update(config=config, split=split, evaluator_version=EVALUATOR_VERSION,
                       weights=weights.as_dict(), convention=convention_of(weights),
                       reference=reference, set=identity,
                       cache=cache_stats)
        if warnings:
            summary["runs_warnings"] = warnings
        if reference:
            summary.update(n_boards_without_reference=len(without),
                           boards_without_reference=without)
        llm = None if runs_dir is None else llm_totals((p[4] for p in plan), _read_sidecar)
        if llm:
            summary["llm"] = llm  # language-model accounting, only when rollouts record it
        label = name or ("Reference" if runs_dir is None else runs_dir.name)
        table = markdown_table([(label, summary)])
        context = {"set_folder": root, "runs": runs_dir, "kicad_version": kicad_version,
                   "pcbdata_version": __version__}
        results = build_results(summary, label, rollout_rows, [p[4] for p in plan],
                                _read_sidecar, context)
        _write_report(out, label, summary, table, rollout_rows, board_rows, results)
        return {"summary": summary, "table": table, "rollouts": rollout_rows,
                "boards": board_rows}


def _check_out(out: Path, root: Path, runs: Path | None) -> None:
    """REPORT is a folder of its own: never inside the board set or the submission (their
    `verify` and listing would then meet the report's files)."""
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: exists and is not a folder (REPORT is a folder)")
    target = out.resolve()
    for what, folder in (("the board set", root), ("RUNS", runs)):
        if folder is not None and target.is_relative_to(folder.resolve()):
            raise UserError(f"--out {out}: inside {what} ({folder}); give a folder outside it")


#: Where reference boards come from, for the message of a split without any.
REFERENCE_SOURCES = ("D3 configs (the routed originals), D1 random-walk configs (the planted "
                     "walks) and D2R sets built with --reference-agent (router-found, where the "
                     "router completed the board)")


def _with_reference(instances: list[tuple[str, Path]], config: str, split: str,
                    limit: int | None) -> tuple[list[tuple[str, Path]], list[str]]:
    """(instances that have a reference board, ids of those that have none); none at all is
    an error: there is nothing to score."""
    having = [(b, d) for b, d in instances if (d / REFERENCE_FILE).is_file()]
    if not having:
        among = f"the first {limit}" if limit is not None else f"its {len(instances)}"
        raise UserError(f"{config}/{split}: none of {among} boards has a reference board "
                        f"({REFERENCE_FILE}); reference boards come with {REFERENCE_SOURCES}")
    return having, [b for b, d in instances if not (d / REFERENCE_FILE).is_file()]


def _without_line(scored: int, without: list[str]) -> str:
    return (f"{len(without)} of {scored + len(without)} boards have no reference board and "
            f"are not scored; the figures are over the {scored} that have one")


def _plan(instances: list[tuple[str, Path]], runs: Path | None, k: int) -> Plan:
    """Every rollout to score; `runs` None scores each instance's reference board (the
    instances given have one: `_with_reference`)."""
    plan = []
    for board_id, directory in instances:
        if runs is None:
            rollouts = [("reference", directory / REFERENCE_FILE)]
        else:
            rollouts = list_rollouts(runs, board_id, k)
            if not rollouts:
                rollouts = [("missing", runs / board_id / "missing.kicad_pcb")]
        for index, (rollout, path) in enumerate(rollouts):
            plan.append((board_id, rollout, index, directory, path))
    return plan


def _score_plan(plan: Plan, instances: list[tuple[str, Path]], out: Path, weights: Weights,
                workers: int, task_timeout: float, progress: bool,
                executor: Executor | str | None = None,
                use_cache: bool = True) -> tuple[list[dict], dict, str | None]:
    """(the record of every rollout of `plan`: from the cache, else scored and cached; what
    the cache gave: `tampered` lines scored again, `used` False with --no-cache; the KiCad
    version of the workers, None if none answered)."""
    cache_path = out / CACHE_NAME
    cache, tampered = load_cache(cache_path) if use_cache else ({}, 0)
    if tampered and progress:
        print(f"pcbdata eval: warning: {cache_path}: {tampered} cached record(s) do not match "
              f"their digest (edited?); those rollouts are scored again", file=sys.stderr)
    limits = (task_timeout, memory_limit_from_env())
    inst_keys = {d: instance_hash(d) for _, d in instances}
    records: list[dict | None] = [None] * len(plan)
    keys: list[str] = []
    routed_hashes: list[str] = []
    todo = []
    for i, (_, _, _, directory, path) in enumerate(plan):
        routed_hash = sha256_file(path) if path.is_file() else "missing"
        routed_hashes.append(routed_hash)
        key = cache_key(inst_keys[directory], routed_hash, weights)
        keys.append(key)
        cached = cache.get(key) or cache.get(limit_cache_key(key, limits))
        if cached is not None:
            records[i] = complete(cached, weights)
        else:
            todo.append(i)
    if progress:
        print(f"pcbdata eval: {len(plan)} rollouts on {len(instances)} boards; "
              f"{len(plan) - len(todo)} cached, {len(todo)} to score", file=sys.stderr)
    stats = {"used": use_cache, "tampered": tampered}  # no run-dependent count: re-runs match
    if not todo:
        with Evaluator(workers=1, task_timeout=task_timeout, executor=executor) as evaluator:
            return [r for r in records if r is not None], stats, engine_version(evaluator.pool)
    with Evaluator(workers=workers, weights=weights, task_timeout=task_timeout,
                   executor=executor) as evaluator, \
            open(cache_path, "a" if use_cache else "w", encoding="utf-8") as cache_file:
        pairs = [(plan[i][3], plan[i][4]) for i in todo]
        for done, (j, record) in enumerate(evaluator.score_many(pairs), start=1):
            i = todo[j]
            record["sha256"] = "" if routed_hashes[i] == "missing" else routed_hashes[i]
            records[i] = record
            _cache_record(cache_file, keys[i], record, limits)
            if progress and (done % 50 == 0 or done == len(todo)):
                print(f"  scored {done}/{len(todo)}", file=sys.stderr)
        version = engine_version(evaluator.pool)
    return [r for r in records if r is not None], stats, version


def engine_version(pool) -> str | None:
    """The KiCad version of `pool`'s workers, or None when no worker answers."""
    try:
        return str(pool.call(KICAD_VERSION))
    except Exception:  # noqa: BLE001 - a worker that cannot start: the version is not known
        return None


def _cache_record(cache_file, key: str, record: dict, limits: tuple[float, int]) -> None:
    if record["reason"].startswith("engine failure"):
        if not is_limit_error(record["reason"].removeprefix("engine failure: ")):
            return  # a crash may not recur: score it again next run
        key = limit_cache_key(key, limits)  # a time-out holds under its limits
    cache_file.write(cache_line(key, record))
    cache_file.flush()


def _rollout_rows(plan: Plan, records: list[dict], reference: bool, warnings: dict) -> list[dict]:
    """Report rows: records with their names and method times; an unusable time becomes a
    warning (`warnings["invalid_times"]`) and no time."""
    rows, bad_times = [], []
    for (board_id, rollout, index, _, path), record in zip(plan, records, strict=True):
        time_s, problem = read_rollout_time(path) if not reference else (None, "")
        if problem:
            bad_times.append({"board_id": board_id, "rollout": rollout, "reason": problem})
        rows.append({**record, "board_id": board_id, "rollout": rollout, "index": index,
                     "time": time_s})
    if not reference:
        warnings["invalid_times"] = bad_times
        timed = [row["time"] is not None for row in rows]
        warnings["untimed"] = ([f"{row['board_id']}/{row['rollout']}" for row in rows
                                if row["time"] is None] if any(timed) else [])
    return rows


def set_line(identity: dict) -> str:
    """The report's line naming the set it scored."""
    verified = ("boards match the manifest" if identity["verified"] else
                f"NOT VERIFIED: {identity['n_problems']} problem(s) against the manifest")
    return (f"Set: {identity['config']} version {identity['set_version']}, manifest sha256 "
            f"{identity['manifest_sha256']}; {verified}; release: {identity['release']}")


def _write_report(out: Path, label: str, summary: dict, table: str, rollout_rows: list[dict],
                  board_rows: list[dict], results: dict) -> None:
    write_atomic(out / RESULTS_FILE, results_text(results))
    write_atomic(out / "per_rollout.csv", _csv(rollout_rows, ROLLOUT_COLUMNS))
    write_atomic(out / "per_board.csv", _csv(board_rows, BOARD_COLUMNS))
    write_atomic(out / "summary.json", json.dumps(summary, indent=1, sort_keys=True) + "\n")
    header = (f"# {label} on {summary['config']} / {summary['split']}\n\n@k = {summary['k']}, "
              f"{summary['n_boards']} boards ({summary['n_boards_scored']} with a scored "
              f"rollout), {summary['n_rollouts']} rollouts ({summary['n_timed']} with a time), "
              f"evaluator {EVALUATOR_VERSION}, scoring convention {summary['convention']}"
              f"\n\n{set_line(summary['set'])}\n\n")
    if summary.get("n_boards_without_reference"):
        header += (_without_line(summary["n_boards"], summary["boards_without_reference"])
                   + ".\n\n")
    write_atomic(out / "summary.md", header + table)

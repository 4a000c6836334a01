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

from pcbdata.errors import UserError
from pcbdata.evaluator.core import EVALUATOR_VERSION, Evaluator, instance_hash, sha256_file
from pcbdata.evaluator.metrics import DEFAULT_WEIGHTS, Weights, pick_best
from pcbdata.fsutil import folder_lock, write_atomic
from pcbdata.kicad.pool import is_limit_error, memory_limit_from_env

TIME_KEYS = ("time_s", "time", "seconds", "wall_time_s")
ROLLOUT_COLUMNS = ["board_id", "rollout", "index", "status", "reason", "cp", "pot", "rout", "drv",
                   "unconnected", "wl", "via", "penalty", "phi", "phi_bare", "net_count", "time",
                   "drv_by_type", "cp_strict", "drv_strict", "pot_strict", "penalty_strict",
                   "phi_strict", "phi_bare_strict", "drv_strict_by_type", "sha256"]
#: What a board row takes from its kept rollout (the @k choice uses the evaluation count).
BEST_FIELDS = ("cp", "pot", "rout", "drv", "unconnected", "wl", "via", "cp_strict", "drv_strict")
BOARD_COLUMNS = ["board_id", "n_rollouts", "n_ok", "n_invalid", "n_parse_fail", "parse_fail",
                 "best_rollout", "cp", "pot", "rout", "drv", "unconnected", "wl", "via", "time",
                 "cp_strict", "drv_strict"]
CACHE_NAME = "scores.jsonl"


def natural_key(name: str) -> list:
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name)]


def list_instances(root: Path, config: str, split: str) -> list[tuple[str, Path]]:
    """(board_id, instance directory) of a built set's config and split, in board-id order."""
    base = root / config / split
    if not base.is_dir():
        configs = sorted(p.name for p in root.iterdir() if p.is_dir()) if root.is_dir() else []
        raise UserError(f"{base}: no such config/split in {root} (configs: {', '.join(configs) or 'none'})")
    boards = sorted((p.name, p) for p in base.iterdir() if (p / "board.kicad_pcb").is_file())
    if not boards:
        raise UserError(f"{base}: holds no boards")
    return boards


def rollout_time(board_file: Path) -> float | None:
    sidecar = board_file.with_suffix(".json")
    if not sidecar.is_file():
        return None
    try:
        data = json.loads(sidecar.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    for key in TIME_KEYS:
        value = data.get(key) if isinstance(data, dict) else None
        if isinstance(value, (int, float)) and math.isfinite(value):
            return float(value)
    return None


def list_rollouts(runs: Path, board_id: str, k: int) -> list[tuple[str, Path]]:
    folder = runs / board_id
    if not folder.is_dir():
        return []
    stems = {p.stem for p in folder.glob("*.kicad_pcb")} | {p.stem for p in folder.glob("*.json")}
    return [(stem, folder / f"{stem}.kicad_pcb") for stem in sorted(stems, key=natural_key)[:k]]


def cache_key(instance_key: str, routed_hash: str, weights: Weights) -> str:
    text = json.dumps([EVALUATOR_VERSION, instance_key, routed_hash, weights.as_dict()],
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def limit_cache_key(key: str, limits: tuple[float, int]) -> str:
    """Cache key of a rollout that hit the engine's time or memory limit (seconds, MiB): the
    same file is not run again under the same limits, and is under other ones."""
    text = json.dumps([key, "limits", float(limits[0]), int(limits[1])])
    return hashlib.sha256(text.encode()).hexdigest()


def load_cache(path: Path) -> dict[str, dict]:
    cache: dict[str, dict] = {}
    if path.is_file():
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                entry = json.loads(line)
                cache[entry["key"]] = entry["record"]
            except (ValueError, KeyError, TypeError):
                continue  # a line cut by an interrupted run
    return cache


def _mean(values: list) -> float | None:
    """Mean of the known values, summed exactly so that the order of the rows cannot change it."""
    values = [v for v in values if v is not None]
    return math.fsum(values) / len(values) if values else None


def board_row(board_id: str, records: list[dict]) -> dict:
    """The @k result of one board from its rollout records."""
    best = pick_best(records)
    n_parse = sum(r["status"] == "parse_fail" for r in records)
    row = {"board_id": board_id, "n_rollouts": len(records),
           "n_ok": sum(r["status"] == "ok" for r in records),
           "n_invalid": sum(r["status"] == "invalid" for r in records),
           "n_parse_fail": n_parse, "parse_fail": int(n_parse == len(records)),
           "time": _mean([r.get("time") for r in records])}
    if best is None:
        row.update({key: None for key in BEST_FIELDS}, best_rollout=None, cp=0, cp_strict=0,
                   rout=0.0)
    else:
        row.update({key: best.get(key) for key in BEST_FIELDS}, best_rollout=best["rollout"])
    return row


def summarize(board_rows: list[dict], rollouts: list[dict], k: int) -> dict:
    """The per-set summary. CP and Rout. average over all boards (a board with no scored
    rollout counts 0); Pot., DRV, WL and Via over boards with a scored rollout; Time over all
    rollouts that report one; parse_fail over boards, parse_fail_at1 and invalid over rollouts."""
    n = len(board_rows)
    n_roll = len(rollouts)
    return {
        "n_boards": n,
        "k": k,
        "cp": _mean([r["cp"] for r in board_rows]),
        "cp_strict": _mean([r.get("cp_strict", 0) for r in board_rows]),
        "pot": _mean([r["pot"] for r in board_rows]),
        "rout": _mean([r["rout"] for r in board_rows]),
        "drv": _mean([r["drv"] for r in board_rows]),
        "drv_strict": _mean([r.get("drv_strict") for r in board_rows]),
        "wl": _mean([r["wl"] for r in board_rows]),
        "via": _mean([r["via"] for r in board_rows]),
        "time": _mean([r.get("time") for r in rollouts]),
        "parse_fail": (sum(r["parse_fail"] for r in board_rows) / n) if n else None,
        "parse_fail_at1": (sum(r["status"] == "parse_fail" for r in rollouts) / n_roll) if n_roll else None,
        "invalid": (sum(r["status"] == "invalid" for r in rollouts) / n_roll) if n_roll else None,
        "n_rollouts": n_roll,
        "n_invalid": sum(r["status"] == "invalid" for r in rollouts),
        "n_parse_fail_rollouts": sum(r["status"] == "parse_fail" for r in rollouts),
        "n_boards_scored": sum(r["best_rollout"] is not None for r in board_rows),
    }


def _fmt(value, digits: int = 2) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def markdown_table(summaries: list[tuple[str, dict]]) -> str:
    """The results table in the benchmark paper's shape (one row per method), then the strict
    count's diagnostic columns CP+ and DRV+ (SPEC 4) and the failure rates."""
    lines = ["| Method | CP (%) | Pot. | Rout. | DRV | WL (mm) | Via | Time (s) | CP+ (%) | DRV+ | Parse-fail (%) | Parse-fail @1 (%) | Invalid (%) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, s in summaries:
        pct = lambda v: "-" if v is None else f"{100 * v:.1f}"  # noqa: E731
        lines.append(f"| {name} | {pct(s['cp'])} | {_fmt(s['pot'])} | {_fmt(s['rout'], 3)} | "
                     f"{_fmt(s['drv'])} | {_fmt(s['wl'], 1)} | {_fmt(s['via'])} | {_fmt(s['time'])} | "
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


def evaluate_set(root: str | Path, config: str, split: str, out: str | Path,
                 runs: str | Path | None = None, k: int = 5, reference: bool = False,
                 workers: int = 1, weights: Weights = DEFAULT_WEIGHTS, name: str | None = None,
                 task_timeout: float = 300.0, progress: bool = True,
                 limit: int | None = None) -> dict:
    """Scores a submission (or the reference boards) on one config/split; writes REPORT files
    and returns the summary. Re-runs reuse scores cached in `out/scores.jsonl` (time and
    memory limits hit too, under the same limits). `limit` scores only the first N boards of
    the split (in board-id order). A second call on the same `out` waits for the first."""
    root, out = Path(root), Path(out)
    if k < 1:
        raise UserError("--k must be at least 1")
    if reference == (runs is not None):
        raise UserError("give either RUNS (--runs) or --reference")
    instances = list_instances(root, config, split)[: limit or None]
    plan = []  # (board_id, rollout name, index, instance dir, routed path)
    for board_id, directory in instances:
        if reference:
            ref = directory / "reference.kicad_pcb"
            if not ref.is_file():
                raise UserError(f"{directory}: no reference.kicad_pcb (only D3 configs have "
                                f"reference boards)")
            rollouts = [("reference", ref)]
        else:
            rollouts = list_rollouts(Path(runs), board_id, k)
            if not rollouts:
                rollouts = [("missing", Path(runs) / board_id / "missing.kicad_pcb")]
        for index, (rollout, path) in enumerate(rollouts):
            plan.append((board_id, rollout, index, directory, path))
    if not reference and not Path(runs).is_dir():
        raise UserError(f"{runs}: no such RUNS directory")
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out, "written"):  # a second eval into REPORT waits: reports never mix
        cache_path = out / CACHE_NAME
        cache = load_cache(cache_path)
        limits = (task_timeout, memory_limit_from_env())
        inst_keys = {d: instance_hash(d) for _, d in instances}
        records: list[dict | None] = [None] * len(plan)
        keys: list[str] = []
        todo = []
        for i, (board_id, rollout, index, directory, path) in enumerate(plan):
            routed_hash = sha256_file(path) if path.is_file() else "missing"
            key = cache_key(inst_keys[directory], routed_hash, weights)
            keys.append(key)
            cached = cache.get(key) or cache.get(limit_cache_key(key, limits))
            if cached is not None:
                records[i] = dict(cached)
            else:
                todo.append(i)
        if progress:
            print(f"pcbdata eval: {len(plan)} rollouts on {len(instances)} boards; "
                  f"{len(plan) - len(todo)} cached, {len(todo)} to score", file=sys.stderr)
        if todo:
            with Evaluator(workers=workers, weights=weights, task_timeout=task_timeout) as evaluator, \
                    open(cache_path, "a", encoding="utf-8") as cache_file:
                pairs = [(plan[i][3], plan[i][4]) for i in todo]
                done = 0
                for j, record in evaluator.score_many(pairs):
                    i = todo[j]
                    done += 1
                    record["sha256"] = sha256_file(plan[i][4]) if plan[i][4].is_file() else ""
                    records[i] = record
                    key = keys[i]
                    if record["reason"].startswith("engine failure"):
                        if not is_limit_error(record["reason"].removeprefix("engine failure: ")):
                            continue  # a crash may not recur: score it again next run
                        key = limit_cache_key(key, limits)  # a time-out holds under its limits
                    cache_file.write(json.dumps({"key": key, "record": record}, sort_keys=True) + "\n")
                    cache_file.flush()
                    if progress and (done % 50 == 0 or done == len(todo)):
                        print(f"  scored {done}/{len(todo)}", file=sys.stderr)
        rollout_rows = []
        for (board_id, rollout, index, directory, path), record in zip(plan, records):
            row = {**record, "board_id": board_id, "rollout": rollout, "index": index,
                   "time": rollout_time(path) if not reference else None}
            rollout_rows.append(row)
        by_board: dict[str, list[dict]] = {}
        for row in rollout_rows:
            by_board.setdefault(row["board_id"], []).append(row)
        board_rows = [board_row(board_id, by_board[board_id]) for board_id, _ in instances]
        summary = summarize(board_rows, rollout_rows, 1 if reference else k)
        summary.update(config=config, split=split, evaluator_version=EVALUATOR_VERSION,
                       weights=weights.as_dict(), reference=reference)
        label = name or ("Reference" if reference else Path(runs).name)
        table = markdown_table([(label, summary)])
        write_atomic(out / "per_rollout.csv", _csv(rollout_rows, ROLLOUT_COLUMNS))
        write_atomic(out / "per_board.csv", _csv(board_rows, BOARD_COLUMNS))
        write_atomic(out / "summary.json", json.dumps(summary, indent=1, sort_keys=True) + "\n")
        header = (f"# {label} on {config} / {split}\n\n@k = {summary['k']}, {summary['n_boards']} boards, "
                  f"{summary['n_rollouts']} rollouts, evaluator {EVALUATOR_VERSION}\n\n")
        write_atomic(out / "summary.md", header + table)
        return {"summary": summary, "table": table, "rollouts": rollout_rows, "boards": board_rows}

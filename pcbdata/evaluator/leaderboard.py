"""`pcbdata leaderboard`: results files (`results.json`) checked and compared in tables.

Every file is validated against the schema and against itself (its boards' figures and its
aggregates must be what its rollouts give); with `rescore`, its boards are scored again from
the set and runs folders it names (`evaluate_set` into a temporary folder) and must give its
figures. Files share a table only when they scored the same set (config, split, set version,
manifest sha256) with the same evaluator and environment version; a file that records no
environment (reference boards, `pcbdata route`) joins the tables of its set and evaluator.
The site (`leaderboard.md`, `index.html`, a page per file) is written to a temporary folder
and moved into place: a refused input leaves nothing written.
"""
from __future__ import annotations

import math
import re
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.tree import list_instances
from pcbdata.evaluator.metrics import Weights
from pcbdata.evaluator.results import BOARD_FIELDS, RESULTS_FILE, derive, read_results
from pcbdata.evaluator.scorer import EVALUATOR_VERSION
from pcbdata.evaluator.site import check_out, table_title, write_site

#: What a table's rows must share, in the order differences are named.
SET_KEYS = ("config", "split", "set_version", "manifest_sha256")
FINGERPRINT_KEYS = (*SET_KEYS, "evaluator_version", "env_version")
#: Figures agree within this (relative and absolute).
TOLERANCE = 1e-9


@dataclass
class Entry:
    """One results file: its path, its data and its name in the site (`slug`)."""

    path: Path
    data: dict
    slug: str = ""


@dataclass
class Table:
    """Rows that may be compared: their shared fingerprint, and why other tables of the same
    config and split are kept apart."""

    fingerprint: dict
    entries: list[Entry]
    notes: list[str] = field(default_factory=list)


def fingerprint(data: dict) -> dict:
    return {**{key: data["set"][key] for key in SET_KEYS},
            "evaluator_version": data["evaluator_version"],
            "env_version": data["env_id"]["version"]}


# ---- checking -----------------------------------------------------------------------------

def _close(a, b) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, int | float) \
            or not isinstance(b, int | float):
        return a == b
    return math.isclose(a, b, rel_tol=TOLERANCE, abs_tol=TOLERANCE)


def first_difference(given, expected, where: str) -> str | None:
    """The first place (a dotted path) where `given` is not `expected`, figures compared
    within `TOLERANCE`, with both values; None when they agree."""
    if isinstance(given, dict) and isinstance(expected, dict):
        for key in sorted(set(given) | set(expected)):
            found = first_difference(given.get(key), expected.get(key), f"{where}.{key}")
            if found:
                return found
        return None
    if isinstance(given, list) and isinstance(expected, list) and len(given) == len(expected):
        for i, (a, b) in enumerate(zip(given, expected, strict=True)):
            label = a.get("board_id", a.get("rollout", i)) if isinstance(a, dict) else i
            found = first_difference(a, b, f"{where}[{label}]")
            if found:
                return found
        return None
    if _close(given, expected):
        return None
    return f"{where} is {_shown(given)}, {_shown(expected)} expected"


def _shown(value) -> str:
    if isinstance(value, list):
        return f"a list of {len(value)}"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def check_own_figures(entry: Entry) -> None:
    """Refuses a file whose boards' figures or aggregates are not what its rollouts give."""
    derived = derive(entry.data)
    boards = [{key: b.get(key) for key in ("board_id", *BOARD_FIELDS)}
              for b in entry.data["boards"]]
    wanted = [{key: b[key] for key in ("board_id", *BOARD_FIELDS)} for b in derived["boards"]]
    found = (first_difference(boards, wanted, "boards")
             or first_difference(entry.data["aggregates"], derived["aggregates"], "aggregates"))
    if entry.data["n_boards"] != len(boards):
        found = found or f"n_boards is {entry.data['n_boards']}, {len(boards)} boards listed"
    if found:
        raise UserError(f"{entry.path}: its figures are not what its own rollouts give "
                        f"({found})")


def load(paths: list[Path]) -> list[Entry]:
    """Every file read, validated and checked against itself, named uniquely for the site."""
    entries = []
    for number, path in enumerate(paths, start=1):
        entry = Entry(Path(path), read_results(Path(path)))
        check_own_figures(entry)
        method = re.sub(r"[^A-Za-z0-9._-]+", "-", entry.data["method"]).strip("-.")[:40]
        entry.slug = f"{number:02d}-{method or 'results'}"
        entries.append(entry)
    return entries


# ---- rescoring ----------------------------------------------------------------------------

def rescore(entry: Entry, set_root: Path | None = None, runs: Path | None = None,
            workers: int = 1, task_timeout: float = 300.0) -> None:
    """Scores the file's boards again (from the set and runs folders it names, or those
    given) and refuses it unless they give its figures: every board, rollout and aggregate."""
    from pcbdata.evaluator.runs import evaluate_set

    data, path = entry.data, entry.path
    if data["evaluator_version"] != EVALUATOR_VERSION:
        raise UserError(f"{path}: scored by evaluator {data['evaluator_version']}, this is "
                        f"{EVALUATOR_VERSION}: its figures cannot be checked by rescoring")
    root = Path(set_root or data["set"]["folder"])
    runs_dir = None if data["reference"] else Path(runs or str(data["runs"]))
    limit = _check_inputs(entry, root, runs_dir)
    with tempfile.TemporaryDirectory(prefix="pcbdata-rescore-") as tmp:
        try:
            evaluate_set(root, data["set"]["config"], data["set"]["split"], Path(tmp) / "report",
                         runs=runs_dir, k=data["budgets"]["k"], reference=data["reference"],
                         workers=workers, weights=Weights(**data["weights"]),
                         name=data["method"], task_timeout=task_timeout, progress=False,
                         limit=limit, allow_unverified=not data["set"]["verified"])
        except UserError as exc:
            raise UserError(f"{path}: cannot be rescored: {exc}") from None
        again = read_results(Path(tmp) / "report" / RESULTS_FILE)
    found = (first_difference(data["boards"], again["boards"], "boards")
             or first_difference(data["aggregates"], again["aggregates"], "aggregates"))
    if found:
        raise UserError(f"{path}: its figures are not what its boards give when rescored "
                        f"({found})")


def _check_inputs(entry: Entry, root: Path, runs: Path | None) -> int | None:
    """The `limit` to rescore with; refuses a file whose set or runs folder is missing, whose
    boards are not its split's, or whose runs folder lacks a board it lists."""
    data, path = entry.data, entry.path
    config, split = data["set"]["config"], data["set"]["split"]
    if not root.is_dir():
        raise UserError(f"{path}: its set folder {root} does not exist (give --set)")
    if runs is not None and not runs.is_dir():
        raise UserError(f"{path}: its runs folder {runs} does not exist (give --runs)")
    try:
        split_ids = [board_id for board_id, _ in list_instances(root, config, split)]
    except UserError as exc:
        raise UserError(f"{path}: a results file of {config}/{split}, which {root} lacks "
                        f"({exc})") from None
    listed = [board["board_id"] for board in data["boards"]]
    expected = split_ids if data["reference"] else split_ids[:len(listed)]
    foreign = [b for b in listed if b not in split_ids]
    if foreign or (not data["reference"] and listed != expected):
        shown = ", ".join((foreign or listed)[:5])
        raise UserError(f"{path}: its boards ({shown}) are not those of {config}/{split} in "
                        f"{root}: a file of another split or set")
    if runs is not None:
        for board in data["boards"]:
            recorded = [r for r in board["rollouts"] if r["rollout"] != "missing"]
            if recorded and not (runs / board["board_id"]).is_dir():
                raise UserError(f"{path}: its runs folder {runs} lacks board "
                                f"{board['board_id']}, which the file lists")
    return None if data["reference"] or len(listed) == len(split_ids) else len(listed)


# ---- tables -------------------------------------------------------------------------------

def group(entries: list[Entry]) -> list[Table]:
    """Tables of comparable files (see the module's doc), ordered by config and split, with
    a note on each naming what sets it apart from other tables of its config and split."""
    strict: dict[tuple, list[Entry]] = {}
    for entry in entries:
        key = tuple(str(v) for k, v in fingerprint(entry.data).items() if k != "env_version")
        strict.setdefault(key, []).append(entry)
    tables = []
    for members in strict.values():
        versions = sorted({e.data["env_id"]["version"] for e in members} - {None})
        for version in versions or [None]:
            rows = [e for e in members if e.data["env_id"]["version"] in (version, None)]
            tables.append(Table({**fingerprint(rows[0].data), "env_version": version}, rows))
    tables.sort(key=lambda t: (t.fingerprint["config"], t.fingerprint["split"],
                               [str(t.fingerprint[k]) for k in FINGERPRINT_KEYS]))
    for table in tables:
        table.notes = _apart_notes(table, tables)
    return tables


def _apart_notes(table: Table, tables: list[Table]) -> list[str]:
    notes = []
    for number, other in enumerate(tables, start=1):
        same = all(other.fingerprint[k] == table.fingerprint[k] for k in ("config", "split"))
        if other is table or not same:
            continue
        differ = [f"{k} {table.fingerprint[k]} vs {other.fingerprint[k]}"
                  for k in FINGERPRINT_KEYS if table.fingerprint[k] != other.fingerprint[k]]
        notes.append(f"kept apart from table {number} ({', '.join(e.slug for e in other.entries)}"
                     f"): {'; '.join(differ)} differ")
    return notes


# ---- the verb -----------------------------------------------------------------------------

def make_leaderboard(paths: list[str | Path], out: str | Path, rescore_files: bool = False,
                     set_root: str | Path | None = None, runs: str | Path | None = None,
                     workers: int = 1, pictures: bool = True, task_timeout: float = 300.0,
                     log: Callable[[str], None] = print) -> dict:
    """Checks the results files (and with `rescore_files` scores them again), groups them and
    writes the site to `out`; returns {"tables", "files", "pictures", "notes"}."""
    out = Path(out)
    check_out(out)
    entries = load([Path(p) for p in paths])
    if rescore_files:
        for entry in entries:
            rescore(entry, Path(set_root) if set_root else None,
                    Path(runs) if runs else None, workers, task_timeout)
            log(f"leaderboard: {entry.path}: rescored, its figures hold")
    tables = group(entries)
    notes = [f"{table_title(n, t)}: {note}" for n, t in enumerate(tables, start=1)
             for note in t.notes]
    drawn = write_site(out, tables, entries, pictures, workers, log)
    return {"tables": len(tables), "files": len(entries), "pictures": drawn, "notes": notes}

"""`pcbdata build d3`: orchestration of the D3 curation with resume.

Flow: scan the checkout (no KiCad) -> one engine task per board that still needs one
(`pcbdata.kicad.upgrade:process_board`, isolated worker, time limit) -> per-board state
saved under `DIR/.d3-state/` -> table, tiers, picks -> the board trees, tables and attribution
-> `manifest.json` last.

Resume: a board's state is keyed by (name, source board sha256, recipe sha256, KiCad version)
and written atomically (files folder first, then the JSON that commits it). A killed build
re-run skips every board whose state exists; per-board work is deterministic (seeded UUIDs),
and every final file is derived from the states only, so the result is byte-identical to an
uninterrupted build. The one exception is the `seconds` column of the curation report, which
is a measurement.
"""
from __future__ import annotations

import json
import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pcbdata import __version__
from pcbdata.core.errors import EngineError, UserError
from pcbdata.core.fsutil import folder_lock, remove_stale_temps, write_atomic, write_dir_atomic
from pcbdata.core.hashing import sha256_bytes, sha256_text
from pcbdata.core.sexpr_text import cut_problem
from pcbdata.core.textio import canonical_json, csv_text
from pcbdata.core.tree import (
    ATTRIBUTION_CSV,
    ATTRIBUTION_JSON,
    BOARD_FILE,
    CHARACTERISTICS_CSV,
    CURATION_REPORT_CSV,
    CURATION_REPORT_JSON,
    D3_STATE_DIR,
    PCBENCH_LICENCE,
    PROJECT_FILE,
    REFERENCE_FILE,
    board_dir,
    folder_holds,
    manifest_path,
)
from pcbdata.curation import attribution as attr
from pcbdata.curation import corpus
from pcbdata.curation.picks import (
    COLUMNS,
    Row,
    assign_tiers,
    evaluation_subsets,
    exclude_after_picks,
    number_rows,
)
from pcbdata.executors import Executor, TaskPool, resolve
from pcbdata.kicad.drc_report import DrcReport
from pcbdata.kicad.pool import KicadError, Outcome, is_limit_error
from pcbdata.model.manifest import FORMAT, d3_facts, merge_configs, read_manifest, write_manifest
from pcbdata.sets.configs import D3_SPLITS, D3_TIERS
from pcbdata.sets.recipe import KeepCriteria, Recipe

STATE_DIR = D3_STATE_DIR
BOARD_FILES = (BOARD_FILE, PROJECT_FILE, REFERENCE_FILE)
REPORT_COLUMNS = ["name", "fate", "reason", "errors", "error_types", "unconnected",
                  "board_identical", "board_id", "source_board_sha256", "seconds", "notes"]
ATTRIBUTION_COLUMNS = ["board_id", "name", "tier", "source_repository", "author", "licence",
                       "licence_from", "redistributable", "collection_licence", "licence_text"]
TASK = "pcbdata.kicad.upgrade:process_board"

Log = Callable[[str], None]


def board_seed(base: int, name: str) -> int:
    return (int(base) ^ int(sha256_text(name)[:8], 16)) & 0xFFFFFFFF


def state_key(board: corpus.SourceBoard, recipe: Recipe, kicad_version: str) -> str:
    text = f"{board.name}\0{board.board_sha256}\0{recipe.sha256}\0{kicad_version}"
    return sha256_text(text)[:32]


def drc_counts(report: DrcReport) -> tuple[dict[str, int], int]:
    """Error-severity violations per type and unconnected items (excluded markers left out)."""
    return report.error_counts()


def judge(result: dict, keep: KeepCriteria) -> dict:
    """The fate of one engine result: plain data for the report and the state."""
    stage = result.get("stage")
    out = {"fate": "", "reason": result.get("error", ""), "errors": 0, "error_types": {},
           "unconnected": 0}
    if stage == "load":
        out["fate"] = corpus.LOAD_FAILURE
    elif stage in ("upgrade", "compat", "bare"):
        out["fate"] = corpus.UPGRADE_FAILURE
    elif stage == "drc" and "drc" not in result:
        out["fate"] = corpus.DRC_FAILURE
    if out["fate"]:
        return out
    types, unconnected = drc_counts(DrcReport.from_dict(result["drc"]))
    out["errors"] = sum(types.values())
    out["error_types"] = dict(sorted(types.items()))
    out["unconnected"] = unconnected
    bare = result.get("bare_facts", {})
    if bare.get("tracks") or bare.get("vias"):
        out["fate"], out["reason"] = corpus.UPGRADE_FAILURE, "bare board still has tracks or vias"
    elif out["errors"] > keep.max_errors:
        out["fate"] = corpus.DRC_FAILURE
        out["reason"] = ", ".join(f"{k}={n}" for k, n in out["error_types"].items())
    elif keep.max_unconnected is not None and unconnected > keep.max_unconnected:
        out["fate"] = corpus.NOT_CONNECTED
        out["reason"] = f"{unconnected} unconnected items"
    else:
        out["fate"] = corpus.KEPT
    return out


class StateStore:
    """Per-board results under DIR/.d3-state/: `<key>.json` commits `<key>/` (the files)."""

    def __init__(self, root: Path):
        self.root = root / STATE_DIR
        self.root.mkdir(parents=True, exist_ok=True)

    def get(self, key: str) -> dict | None:
        path = self.root / f"{key}.json"
        if not path.is_file():
            return None
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return None

    def files(self, key: str) -> dict[str, bytes]:
        folder = self.root / key
        return {name: (folder / name).read_bytes() for name in BOARD_FILES}

    def put(self, key: str, state: dict, files: dict[str, bytes] | None) -> None:
        if files:
            write_dir_atomic(self.root / key, dict[str, bytes | str](files))
        write_atomic(self.root / f"{key}.json", canonical_json(state))


def _write_if_changed(path: Path, data: bytes | str) -> None:
    raw = data.encode("utf-8") if isinstance(data, str) else data
    if path.is_file() and path.read_bytes() == raw:
        return
    write_atomic(path, raw)


def _engine_kicad_version(pool: TaskPool) -> str:
    """KiCad's version from a worker (it starts one), under a limit of at least 2 minutes
    whatever the per-board limit."""
    saved = pool.task_timeout
    pool.task_timeout = max(float(saved), 120.0)
    try:
        return str(pool.call("pcbdata.kicad.basics:kicad_version"))
    except KicadError as exc:
        raise EngineError(f"cannot start KiCad (pcbnew) in a worker: {exc}") from None
    finally:
        pool.task_timeout = saved


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def build(source: str | Path, out: str | Path, recipe: Recipe, workers: int = 2,
          log: Log | None = None, pool: TaskPool | None = None,
          tasks_per_worker: int = 20, executor: Executor | str | None = None) -> dict:
    """Builds the D3 set of `source` into `out`; returns the summary (fate and tier counts).

    `tasks_per_worker`: KiCad keeps memory between boards (tens of MB each), so workers are
    recycled after this many boards; it does not change the output. The boards run on `pool`,
    else on a pool of `executor` (default: this machine's workers). The folder is locked
    for the build (`fsutil.folder_lock`): a second build into it waits.
    """
    with folder_lock(out, "built"):  # a second build into the folder waits for this one
        if pool is None:
            pool = resolve(executor).pool(workers=workers,
                                          task_timeout=recipe.engine.task_timeout_s,
                                          tasks_per_worker=tasks_per_worker)
            with pool:
                return _build(Path(source), Path(out), recipe, log or _stderr, pool)
        return _build(Path(source), Path(out), recipe, log or _stderr, pool)


def limit_state_key(key: str, pool) -> str:
    """State key of a board that hit the pool's time or memory limit: the same board under
    the same limits is not run again by a resumed build (a raised limit runs it again)."""
    limits = f"{key}\0{float(pool.task_timeout):g}\0{getattr(pool, 'memory_limit_mb', 0)}"
    return sha256_text(limits)[:32]


def _cut_board(board: corpus.SourceBoard) -> dict | None:
    """The load-failure state of a truncated board file, decided before KiCad sees it: KiCad
    can spin on such a file until the time limit."""
    problem = cut_problem(board.board_path.read_bytes())
    if problem is None:
        return None
    return {"fate": corpus.LOAD_FAILURE, "reason": f"load: {problem}", "errors": 0,
            "error_types": {}, "unconnected": 0, "seconds": 0.0}


def _build(source: Path, out: Path, recipe: Recipe, log: Log, pool: TaskPool) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    remove_stale_temps(out)
    started = time.perf_counter()

    boards = corpus.scan(source, recipe)
    if not boards:
        raise UserError(f"{source}: no board folders under {recipe.source.boards_dir}/")
    log(f"d3: {len(boards)} board folders in {source}; recipe {recipe.version} "
        f"({recipe.sha256[:12]})")
    for b in boards:  # e.g. an unusable metadata.json: the board goes on, the note is kept
        for note in b.notes:
            log(f"d3: warning: {b.name}: {note}")
    _retract_manifest(out)

    kicad_version = _engine_kicad_version(pool)
    wanted = recipe.engine.kicad_version
    if wanted and not kicad_version.startswith(wanted):
        log(f"d3: warning: the recipe was made with KiCad {wanted}, this is KiCad "
            f"{kicad_version}; verdicts may differ (the manifest records the version)")
    store = StateStore(out)
    states = _process(boards, recipe, kicad_version, store, pool, log)

    summary = _finish(source, out, recipe, boards, states, store, kicad_version)
    summary["wall_seconds"] = round(time.perf_counter() - started, 1)
    for warning in summary["warnings"]:
        log(f"d3: warning: {warning}")
    fates = summary["fates"]
    log("d3: fates: " + ", ".join(f"{k} {fates.get(k, 0)}" for k in corpus.FATES))
    log("d3: tiers: " + ", ".join(f"{c} {n['full']} (test {n['test']})"
                                  for c, n in summary["tiers"].items()))
    return summary


def _process(boards: list[corpus.SourceBoard], recipe: Recipe, kicad_version: str,
             store: StateStore, pool: TaskPool, log: Log) -> dict[str, dict]:
    """The state of every board: known without KiCad, resumed, or made by an engine task."""
    states: dict[str, dict] = {}
    todo = []
    for b in boards:
        if b.fate:
            states[b.name] = {"fate": b.fate, "reason": b.reason, "errors": 0,
                              "error_types": {}, "unconnected": 0, "seconds": 0.0}
            continue
        key = state_key(b, recipe, kicad_version)
        cached = store.get(key) or store.get(limit_state_key(key, pool)) or _cut_board(b)
        if cached is not None:
            states[b.name] = cached
        else:
            todo.append((b, key))
    log(f"d3: {len(boards) - len(todo)} boards known (resumed or decided without KiCad), "
        f"{len(todo)} to process with {pool.workers} workers")
    compat, keep = recipe.compat.as_table(), recipe.keep.as_table()
    args = [(str(b.board_path), board_seed(recipe.engine.uuid_seed, b.name), compat, keep)
            for b, _ in todo]
    for done, outcome in enumerate(pool.map(TASK, args), start=1):
        b, key = todo[outcome.index]
        state, files = _state(outcome, recipe.keep, key, b.name)
        if state["fate"] != corpus.ENGINE_FAILURE:
            store.put(key, state, files)
        elif is_limit_error(outcome.error):  # a crash is retried by the next run
            store.put(limit_state_key(key, pool), state, None)
        states[b.name] = state
        reason = f" ({state['reason']})" if state["reason"] else ""
        log(f"[{done}/{len(todo)}] {b.name}: {state['fate']}{reason} {outcome.seconds:.1f} s")
    return states


def _state(outcome: Outcome, keep: KeepCriteria, key: str,
           name: str) -> tuple[dict, dict[str, bytes] | None]:
    """The state of one board from its engine outcome, and its files if it is kept."""
    if outcome.ok:
        verdict, value = judge(outcome.value, keep), outcome.value
    else:
        verdict = {"fate": corpus.ENGINE_FAILURE, "reason": outcome.error, "errors": 0,
                   "error_types": {}, "unconnected": 0}
        value = {}
    state = {**verdict, "seconds": round(outcome.seconds, 3),
             "facts": value.get("facts", {}), "bare_facts": value.get("bare_facts", {}),
             "compat": value.get("compat", {}), "timings": value.get("timings", {}),
             "uuids_fixed": value.get("uuids_fixed", 0), "key": key, "name": name}
    return state, (value.get("files") if verdict["fate"] == corpus.KEPT else None)


def _retract_manifest(out: Path) -> None:
    """While a build runs the folder holds no complete D3 set: drop D3 configs from it."""
    if not manifest_path(out).is_file():
        return
    try:
        old = read_manifest(out)
    except Exception:  # noqa: BLE001 - an unreadable manifest is rewritten at the end anyway
        manifest_path(out).unlink()
        return
    configs = {k: v for k, v in old.get("configs", {}).items() if k not in D3_TIERS.values()}
    if configs != old.get("configs"):
        if configs:
            write_manifest(out, {**old, "configs": configs})
        else:
            manifest_path(out).unlink()


@dataclass
class _Curated:
    """What the kept boards become: the characteristics table, tiers, test subsets."""

    boards: list[corpus.SourceBoard]
    by_name: dict[str, corpus.SourceBoard]
    states: dict[str, dict]
    rows: list[Row]
    tiers: dict[str, list[Row]]
    subsets: dict[str, list[Row]]
    notes: list[dict]
    attributions: dict[str, dict]
    snapshot: str
    warnings: list[str]  # test splits not the published ones; corpus files skipped (...)


def _curate(source: Path, recipe: Recipe, boards: list[corpus.SourceBoard],
            states: dict[str, dict]) -> _Curated:
    by_name = {b.name: b for b in boards}
    kept = [b for b in boards if states[b.name]["fate"] == corpus.KEPT]
    rows = number_rows([Row(name=b.name, nets=b.nets, pads=b.pads,
                            components=int(states[b.name]["facts"]["components"]),
                            layers=int(states[b.name]["facts"]["copper_layers"]))
                        for b in kept])
    tiers = assign_tiers(rows, recipe.tiers.a_size, recipe.tiers.b_max_pads)
    subsets, notes = evaluation_subsets(tiers, recipe)
    rows, after = exclude_after_picks(rows, tiers, subsets, recipe.overrides("exclude_after_picks"))
    notes += after
    for note in after:
        if note["applied"]:
            states[note["board"]] = {**states[note["board"]], "fate": corpus.EXCLUDED,
                                     "reason": note["reason"]}
    warnings = [f"{n['config']}: {n['why']}" for n in notes
                if n["kind"] == "published_test" and not n["applied"]]
    github = attr.load_github_licences(source, recipe, warnings)
    attributions = {r.name: attr.attribute(r.name, by_name[r.name].metadata, github, recipe)
                    for r in rows}
    return _Curated(boards, by_name, states, rows, tiers, subsets, notes, attributions,
                    corpus.snapshot_sha256(boards), warnings)


def _finish(source: Path, out: Path, recipe: Recipe, boards: list[corpus.SourceBoard],
            states: dict[str, dict], store: StateStore, kicad_version: str) -> dict:
    """Writes the board trees, the tables and the manifest (last); returns the summary."""
    cur = _curate(source, recipe, boards, states)
    configs: dict[str, dict] = {}
    expected: set[Path] = set()
    for tier, config in D3_TIERS.items():
        splits = {}
        for split in D3_SPLITS:
            members = cur.subsets[tier] if split == "test" else cur.tiers[tier]
            entries = {r.board_id: _write_board(out, config, split, r, cur, store, expected)
                       for r in members}
            # every board was loaded and DRC-checked by KiCad (count, as for D1/D2)
            splits[split] = {"count": len(entries), "kicad_checked": len(entries),
                             "boards": entries}
        configs[config] = _config_entry(recipe, tier, len(boards), cur.snapshot, kicad_version,
                                        splits)
        published = [n["applied"] for n in cur.notes
                     if n["kind"] == "published_test" and n["config"] == config]
        if published:  # whether the test split is the published one (SPEC 3, step 9)
            configs[config]["published_test"] = published[0]
    _remove_stale_boards(out, expected)
    summary = _write_tables(source, out, recipe, cur, kicad_version)
    base = {"format": FORMAT, "package_version": __version__, "kicad_version": kicad_version}
    write_manifest(out, merge_configs(out, base, configs))
    return summary


def _write_board(out: Path, config: str, split: str, r: Row, cur: _Curated, store: StateStore,
                 expected: set[Path]) -> dict:
    """Writes one board folder (unless it already holds the bytes); returns its entry."""
    state = cur.states[r.name]
    files = store.files(state["key"])
    folder = board_dir(out, config, split, r.board_id)
    expected.add(folder)
    if not folder_holds(folder, files):
        write_dir_atomic(folder, dict[str, bytes | str](files))
    a = cur.attributions[r.name]
    return {
        "files": {n: sha256_bytes(files[n]) for n in BOARD_FILES},
        "name": r.name, "row": r.row,
        **d3_facts(nets=r.nets, pads=r.pads, components=r.components, layers=r.layers),
        "source_board_sha256": cur.by_name[r.name].board_sha256,
        "source_repository": a["source_repository"], "author": a["author"],
        "licence": a["licence"], "redistributable": a["redistributable"],
        "pcbench_licence": a["collection_licence"],
        "compat_board_identical": bool(state["compat"].get("board_identical")),
    }


def _config_entry(recipe: Recipe, tier: str, boards: int, snapshot: str, kicad_version: str,
                  splits: dict) -> dict:
    return {
        "family": "d3", "set_version": recipe.version, "tier": tier,
        "recipe": {"name": recipe.name, "version": recipe.version, "sha256": recipe.sha256},
        "recipe_version": recipe.version, "recipe_sha256": recipe.sha256,
        "parameters": recipe.data,
        "source": {"upstream": recipe.source.upstream, "commit": recipe.source.commit,
                   "snapshot_sha256": snapshot, "boards": boards},
        "kicad_version": kicad_version,
        "splits": splits,
    }


def _write_tables(source: Path, out: Path, recipe: Recipe, cur: _Curated,
                  kicad_version: str) -> dict:
    """characteristics.csv, the curation report, attribution and PCBench's licence notice;
    returns the summary (fates, tier counts, overrides)."""
    table = [{"board_id": r.board_id, "name": r.name, "nets": r.nets,
              "components": r.components, "pads": r.pads, "layers": r.layers,
              "tier": r.tier, "in_test": int(r.in_test)} for r in cur.rows]
    _write_if_changed(out / CHARACTERISTICS_CSV, csv_text(table, COLUMNS))
    report = _report_rows(cur)
    fates = {f: sum(1 for r in report if r["fate"] == f) for f in corpus.FATES}
    tier_counts = {D3_TIERS[t]: {"full": len(cur.tiers[t]), "test": len(cur.subsets[t])}
                   for t in cur.tiers}
    report_csv = [{**r, "error_types": ";".join(f"{k}={n}" for k, n in r["error_types"].items())}
                  for r in report]
    _write_if_changed(out / CURATION_REPORT_CSV, csv_text(report_csv, REPORT_COLUMNS))
    _write_if_changed(out / CURATION_REPORT_JSON, canonical_json({
        "recipe": {"version": recipe.version, "sha256": recipe.sha256},
        "kicad_version": kicad_version, "source_snapshot_sha256": cur.snapshot,
        "fates": fates, "tiers": tier_counts, "overrides": cur.notes, "warnings": cur.warnings,
        "boards": report}))
    _write_attribution(source, out, recipe, cur)
    return {"fates": fates, "tiers": tier_counts, "overrides": cur.notes,
            "boards": len(cur.boards), "warnings": cur.warnings}


def _report_rows(cur: _Curated) -> list[dict]:
    """One row per source board: its fate and why, in name order."""
    board_ids = {r.name: r.board_id for r in cur.rows}
    report = []
    for b in cur.boards:
        s = cur.states[b.name]
        report.append({
            "name": b.name, "fate": s["fate"], "reason": s.get("reason", ""),
            "errors": s.get("errors", 0), "error_types": s.get("error_types", {}),
            "unconnected": s.get("unconnected", 0),
            "board_identical": s.get("compat", {}).get("board_identical", ""),
            "board_id": board_ids.get(b.name, ""), "source_board_sha256": b.board_sha256,
            "uuids_fixed": s.get("uuids_fixed", 0), "seconds": s.get("seconds", 0.0),
            "notes": "; ".join(b.notes)})
    return report


def _write_attribution(source: Path, out: Path, recipe: Recipe, cur: _Curated) -> None:
    rows = [{"board_id": r.board_id, **cur.attributions[r.name], "tier": r.tier}
            for r in cur.rows]
    _write_if_changed(out / ATTRIBUTION_CSV, csv_text(rows, ATTRIBUTION_COLUMNS))
    _write_if_changed(out / ATTRIBUTION_JSON, canonical_json({
        "collection": {"name": "PCBench", "upstream": recipe.source.upstream,
                       "commit": recipe.source.commit,
                       "licence": recipe.source.collection_licence,
                       "notice_file": PCBENCH_LICENCE},
        "boards": rows}))
    licence = source / recipe.source.licence_file
    if licence.is_file():
        _write_if_changed(out / PCBENCH_LICENCE, licence.read_bytes())


def _remove_stale_boards(out: Path, expected: set[Path]) -> None:
    """Board folders of an earlier build that this build does not produce."""
    for config in D3_TIERS.values():
        for split in D3_SPLITS:
            folder = out / config / split
            if not folder.is_dir():
                continue
            for child in folder.iterdir():
                if child.is_dir() and child not in expected:
                    shutil.rmtree(child)

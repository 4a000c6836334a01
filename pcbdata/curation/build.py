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

import csv
import hashlib
import io
import json
import shutil
import sys
import time
from pathlib import Path
from typing import Callable

from pcbdata import __version__
from pcbdata.curation import attribution as attr
from pcbdata.curation import corpus
from pcbdata.curation.picks import COLUMNS, CONFIGS, Row, assign_tiers, evaluation_subsets, \
    number_rows
from pcbdata.curation.recipe import Recipe
from pcbdata.kicad.drc_report import DrcReport
from pcbdata.fsutil import remove_stale_temps, sha256_bytes, write_atomic, write_dir_atomic
from pcbdata.manifest import FORMAT, manifest_path, merge_configs, read_manifest, \
    write_manifest

STATE_DIR = ".d3-state"
BOARD_FILES = ("board.kicad_pcb", "board.kicad_pro", "reference.kicad_pcb")
SPLITS = ("test", "full")
REPORT_COLUMNS = ["name", "fate", "reason", "errors", "error_types", "unconnected",
                  "board_identical", "board_id", "source_board_sha256", "seconds", "notes"]
TASK = "pcbdata.kicad.upgrade:process_board"


def board_seed(base: int, name: str) -> int:
    return (int(base) ^ int(hashlib.sha256(name.encode("utf-8")).hexdigest()[:8], 16)) \
        & 0xFFFFFFFF


def state_key(board: corpus.SourceBoard, recipe: Recipe, kicad_version: str) -> str:
    text = f"{board.name}\0{board.board_sha256}\0{recipe.sha256}\0{kicad_version}"
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:32]


def drc_counts(report: DrcReport) -> tuple[dict[str, int], int]:
    """Error-severity violations per type and unconnected items (excluded markers left out)."""
    types: dict[str, int] = {}
    unconnected = 0
    for v in report.violations:
        if v.severity == "excluded":
            continue
        if v.section == "unconnected":
            unconnected += 1
        elif v.severity == "error":
            types[v.type] = types.get(v.type, 0) + 1
    return types, unconnected


def is_kept(report: DrcReport, keep: dict) -> bool:
    """The revalidation rule of the recipe's `[keep]` table."""
    types, unconnected = drc_counts(report)
    return sum(types.values()) <= int(keep["max_errors"]) and unconnected <= int(keep["max_unconnected"])


def judge(result: dict, keep: dict) -> dict:
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
    elif out["errors"] > int(keep["max_errors"]):
        out["fate"] = corpus.DRC_FAILURE
        out["reason"] = ", ".join(f"{k}={n}" for k, n in out["error_types"].items())
    elif unconnected > int(keep["max_unconnected"]):
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
            write_dir_atomic(self.root / key, files)
        write_atomic(self.root / f"{key}.json",
                     json.dumps(state, indent=1, sort_keys=True) + "\n")


def _csv(rows: list[dict], columns: list[str]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n",
                            extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow(row)
    return buffer.getvalue()


def _json(data) -> str:
    return json.dumps(data, indent=1, sort_keys=True, ensure_ascii=False) + "\n"


def _write_if_changed(path: Path, data: bytes | str) -> None:
    raw = data.encode("utf-8") if isinstance(data, str) else data
    if path.is_file() and path.read_bytes() == raw:
        return
    write_atomic(path, raw)


def _engine_kicad_version(pool) -> str:
    """KiCad's version from a worker (it starts one), under a limit of at least 2 minutes
    whatever the per-board limit."""
    from pcbdata.kicad.pool import KicadError
    from pcbdata.errors import UserError

    saved = pool.task_timeout
    pool.task_timeout = max(float(saved), 120.0)
    try:
        return str(pool.call("pcbdata.kicad.upgrade:kicad_version"))
    except KicadError as exc:
        raise UserError(f"cannot start KiCad (pcbnew) in a worker: {exc}") from None
    finally:
        pool.task_timeout = saved


def build(source: str | Path, out: str | Path, recipe: Recipe, workers: int = 2,
          log: Callable[[str], None] | None = None, pool=None,
          tasks_per_worker: int = 20) -> dict:
    """Builds the D3 set of `source` into `out`; returns the summary (fate and tier counts).

    `tasks_per_worker`: KiCad keeps memory between boards (tens of MB each), so workers are
    recycled after this many boards; it does not change the output.
    """
    from pcbdata.kicad.pool import KicadPool

    log = log or (lambda line: print(line, file=sys.stderr, flush=True))
    source, out = Path(source), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    remove_stale_temps(out)
    started = time.perf_counter()

    boards = corpus.scan(source, recipe)
    if not boards:
        from pcbdata.errors import UserError
        raise UserError(f"{source}: no board folders under {recipe['source']['boards_dir']}/")
    log(f"d3: {len(boards)} board folders in {source}; recipe {recipe.version} "
        f"({recipe.sha256[:12]})")
    for b in boards:  # e.g. an unusable metadata.json: the board goes on, the note is kept
        for note in b.notes:
            log(f"d3: warning: {b.name}: {note}")
    _retract_manifest(out)

    engine = recipe["engine"]
    own_pool = pool is None
    if own_pool:
        pool = KicadPool(workers=workers, task_timeout=float(engine["task_timeout_s"]),
                          tasks_per_worker=tasks_per_worker)
    try:
        kicad_version = _engine_kicad_version(pool)
        wanted = str(engine.get("kicad_version", ""))
        if wanted and not kicad_version.startswith(wanted):
            log(f"d3: warning: the recipe was made with KiCad {wanted}, this is KiCad "
                f"{kicad_version}; verdicts may differ (the manifest records the version)")
        store = StateStore(out)
        states: dict[str, dict] = {}
        todo = []
        for b in boards:
            if b.fate:
                states[b.name] = {"fate": b.fate, "reason": b.reason, "errors": 0,
                                  "error_types": {}, "unconnected": 0, "seconds": 0.0}
                continue
            key = state_key(b, recipe, kicad_version)
            cached = store.get(key)
            if cached is not None:
                states[b.name] = cached
            else:
                todo.append((b, key))
        log(f"d3: {len(boards) - len(todo)} boards known (resumed or decided without KiCad), "
            f"{len(todo)} to process with {pool.workers} workers")
        args = [(str(b.board_path), board_seed(engine["uuid_seed"], b.name), recipe["compat"],
                 recipe["keep"]) for b, _ in todo]
        done = 0
        for outcome in pool.map(TASK, args):
            b, key = todo[outcome.index]
            done += 1
            if outcome.ok:
                verdict = judge(outcome.value, recipe["keep"])
                value = outcome.value
            else:
                verdict = {"fate": corpus.ENGINE_FAILURE, "reason": outcome.error, "errors": 0,
                           "error_types": {}, "unconnected": 0}
                value = {}
            state = {**verdict, "seconds": round(outcome.seconds, 3),
                     "facts": value.get("facts", {}), "bare_facts": value.get("bare_facts", {}),
                     "compat": value.get("compat", {}), "timings": value.get("timings", {}),
                     "uuids_fixed": value.get("uuids_fixed", 0),
                     "key": key, "name": b.name}
            files = value.get("files") if verdict["fate"] == corpus.KEPT else None
            if verdict["fate"] != corpus.ENGINE_FAILURE:  # a crash or time limit is retried
                store.put(key, state, files)               # by the next run

            states[b.name] = state
            log(f"[{done}/{len(todo)}] {b.name}: {verdict['fate']}"
                f"{' (' + verdict['reason'] + ')' if verdict['reason'] else ''} "
                f"{outcome.seconds:.1f} s")
    finally:
        if own_pool:
            pool.close()

    summary = _finish(source, out, recipe, boards, states, store, kicad_version)
    summary["wall_seconds"] = round(time.perf_counter() - started, 1)
    for warning in summary["warnings"]:
        log(f"d3: warning: {warning}")
    fates = summary["fates"]
    log("d3: fates: " + ", ".join(f"{k} {fates.get(k, 0)}" for k in corpus.FATES))
    log("d3: tiers: " + ", ".join(f"{c} {n['full']} (test {n['test']})"
                                  for c, n in summary["tiers"].items()))
    return summary


def _retract_manifest(out: Path) -> None:
    """While a build runs the folder holds no complete D3 set: drop D3 configs from it."""
    if not manifest_path(out).is_file():
        return
    try:
        old = read_manifest(out)
    except Exception:  # noqa: BLE001 - an unreadable manifest is rewritten at the end anyway
        manifest_path(out).unlink()
        return
    configs = {k: v for k, v in old.get("configs", {}).items() if k not in CONFIGS.values()}
    if configs != old.get("configs"):
        if configs:
            write_manifest(out, {**old, "configs": configs})
        else:
            manifest_path(out).unlink()


def _finish(source: Path, out: Path, recipe: Recipe, boards: list[corpus.SourceBoard],
            states: dict[str, dict], store: StateStore, kicad_version: str) -> dict:
    by_name = {b.name: b for b in boards}
    kept = [b for b in boards if states[b.name]["fate"] == corpus.KEPT]
    rows = number_rows([Row(name=b.name, nets=b.nets, pads=b.pads,
                            components=int(states[b.name]["facts"]["components"]),
                            layers=int(states[b.name]["facts"]["copper_layers"]))
                        for b in kept])
    tiers_cfg = recipe["tiers"]
    tiers = assign_tiers(rows, int(tiers_cfg["a_size"]), int(tiers_cfg["b_max_pads"]))
    subsets, notes = evaluation_subsets(tiers, recipe)
    warnings: list[str] = []
    github = attr.load_github_licences(source, recipe, warnings)
    attributions = {r.name: attr.attribute(r.name, by_name[r.name].metadata, github, recipe)
                    for r in rows}

    # board trees
    expected: set[Path] = set()
    manifest_configs = {}
    snapshot = corpus.snapshot_sha256(boards)
    for tier, config in CONFIGS.items():
        splits = {}
        for split in SPLITS:
            members = subsets[tier] if split == "test" else tiers[tier]
            entries = {}
            for r in members:
                state = states[r.name]
                files = store.files(state["key"])
                folder = out / config / split / r.board_id
                expected.add(folder)
                if not (folder.is_dir() and all(
                        (folder / n).is_file() and (folder / n).read_bytes() == files[n]
                        for n in BOARD_FILES)
                        and sorted(p.name for p in folder.iterdir()) == sorted(BOARD_FILES)):
                    write_dir_atomic(folder, files)
                a = attributions[r.name]
                entries[r.board_id] = {
                    "files": {n: sha256_bytes(files[n]) for n in BOARD_FILES},
                    "name": r.name, "row": r.row, "pads": r.pads, "nets": r.nets,
                    "components": r.components, "layers": r.layers,
                    "source_board_sha256": by_name[r.name].board_sha256,
                    "source_repository": a["source_repository"], "author": a["author"],
                    "licence": a["licence"], "redistributable": a["redistributable"],
                    "pcbench_licence": a["collection_licence"],
                    "compat_board_identical": bool(state["compat"].get("board_identical")),
                }
            # every board was loaded and DRC-checked by KiCad (count, as for D1/D2)
            splits[split] = {"count": len(entries), "kicad_checked": len(entries),
                             "boards": entries}
        manifest_configs[config] = {
            "family": "d3", "set_version": recipe.version, "tier": tier,
            "recipe": {"name": recipe["recipe"]["name"], "version": recipe.version,
                       "sha256": recipe.sha256},
            "recipe_version": recipe.version, "recipe_sha256": recipe.sha256,
            "parameters": recipe.data,
            "source": {"upstream": recipe["source"].get("upstream", ""),
                       "commit": recipe["source"].get("commit", ""),
                       "snapshot_sha256": snapshot, "boards": len(boards)},
            "kicad_version": kicad_version,
            "splits": splits,
        }
    _remove_stale_boards(out, expected)

    # tables
    table = [{"board_id": r.board_id, "name": r.name, "nets": r.nets,
              "components": r.components, "pads": r.pads, "layers": r.layers,
              "tier": r.tier, "in_test": int(r.in_test)} for r in rows]
    _write_if_changed(out / "characteristics.csv", _csv(table, COLUMNS))
    board_ids = {r.name: r.board_id for r in rows}
    report = []
    for b in boards:
        s = states[b.name]
        report.append({
            "name": b.name, "fate": s["fate"], "reason": s.get("reason", ""),
            "errors": s.get("errors", 0), "error_types": s.get("error_types", {}),
            "unconnected": s.get("unconnected", 0),
            "board_identical": s.get("compat", {}).get("board_identical", ""),
            "board_id": board_ids.get(b.name, ""), "source_board_sha256": b.board_sha256,
            "uuids_fixed": s.get("uuids_fixed", 0), "seconds": s.get("seconds", 0.0),
            "notes": "; ".join(b.notes)})
    report_csv = [{**r, "error_types": ";".join(f"{k}={n}" for k, n in r["error_types"].items())}
                  for r in report]
    fates = {f: sum(1 for r in report if r["fate"] == f) for f in corpus.FATES}
    tier_counts = {CONFIGS[t]: {"full": len(tiers[t]), "test": len(subsets[t])} for t in tiers}
    _write_if_changed(out / "curation_report.csv", _csv(report_csv, REPORT_COLUMNS))
    _write_if_changed(out / "curation_report.json", _json({
        "recipe": {"version": recipe.version, "sha256": recipe.sha256},
        "kicad_version": kicad_version, "source_snapshot_sha256": snapshot,
        "fates": fates, "tiers": tier_counts, "overrides": notes, "warnings": warnings,
        "boards": report}))

    # attribution
    attr_rows = [{"board_id": r.board_id, **attributions[r.name], "tier": r.tier}
                 for r in rows]
    attr_cols = ["board_id", "name", "tier", "source_repository", "author", "licence",
                 "licence_from", "redistributable", "collection_licence", "licence_text"]
    _write_if_changed(out / "attribution.csv", _csv(attr_rows, attr_cols))
    _write_if_changed(out / "attribution.json", _json({
        "collection": {"name": "PCBench", "upstream": recipe["source"].get("upstream", ""),
                       "commit": recipe["source"].get("commit", ""),
                       "licence": recipe["source"].get("collection_licence", "MIT"),
                       "notice_file": "LICENSE-PCBench"},
        "boards": attr_rows}))
    licence = source / recipe["source"].get("licence_file", "LICENSE")
    if licence.is_file():
        _write_if_changed(out / "LICENSE-PCBench", licence.read_bytes())

    base = {"format": FORMAT, "package_version": __version__, "kicad_version": kicad_version}
    write_manifest(out, merge_configs(out, base, manifest_configs))
    return {"fates": fates, "tiers": tier_counts, "overrides": notes, "boards": len(boards),
            "warnings": warnings}


def _remove_stale_boards(out: Path, expected: set[Path]) -> None:
    """Board folders of an earlier build that this build does not produce."""
    for config in CONFIGS.values():
        for split in SPLITS:
            folder = out / config / split
            if not folder.is_dir():
                continue
            for child in folder.iterdir():
                if child.is_dir() and child not in expected:
                    shutil.rmtree(child)

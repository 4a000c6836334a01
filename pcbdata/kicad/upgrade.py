"""D3 per-board engine work: KiCad 9 upgrade, project compatibility pass, DRC, bare board.

Runs inside `KicadPool` worker processes only (one task per source board, see
`process_board`). Every file is written under a fresh work folder with plain names, so board
names with spaces, quotes or parentheses never reach KiCad, and KiCad's project cache (which
keys projects by path) never serves a stale project: each DRC runs on a path loaded for the
first time.

UUIDs: KiCad mints new UUIDs when it upgrades a legacy board. `pcbnew.KIID.SeedGenerator(seed)`
is called before every load, so the same source board and seed give the same bytes in any
worker, whatever it did before.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
import time
from pcbdata.kicad.basics import board_drc_text, pcbnew_module as _pcbnew

BOARD = "board.kicad_pcb"
PROJECT = "board.kicad_pro"
REFERENCE = "reference.kicad_pcb"

_ACTUAL = re.compile(r"actual ([0-9.]+) mm")


def _sha(path: str) -> str:
    with open(path, "rb") as handle:
        return hashlib.sha256(handle.read()).hexdigest()


def _unload_projects() -> None:
    """Drops every project KiCad keeps loaded, so memory and stale settings do not pile up."""
    pcbnew = _pcbnew()
    try:
        manager = pcbnew.GetSettingsManager()
        for project in list(manager.GetOpenProjects()):
            proj = manager.GetProject(project)
            if proj is not None:
                manager.UnloadProject(proj, False)
    except Exception:  # noqa: BLE001 - best effort; the pool recycles workers anyway
        pass


def _load(path: str, seed: int):
    pcbnew = _pcbnew()
    pcbnew.KIID.SeedGenerator(seed)
    board = pcbnew.LoadBoard(path)
    if board is None:
        raise ValueError("KiCad could not load the board")
    return board


def _drc(board_path: str, seed: int) -> str:
    """DRC report text of a board with the project next to it (all track errors)."""
    return board_drc_text(_load(board_path, seed), board_path)


def _stage(folder: str, board_bytes: bytes, project_text: str) -> str:
    os.makedirs(folder)
    with open(os.path.join(folder, BOARD), "wb") as handle:
        handle.write(board_bytes)
    with open(os.path.join(folder, PROJECT), "w", encoding="utf-8") as handle:
        handle.write(project_text)
    return os.path.join(folder, BOARD)


def min_copper_spacing(board_bytes: bytes, project: dict, work: str, seed: int,
                       probe_mm: float) -> float | None:
    """Smallest positive spacing between copper of different nets, as KiCad's DRC measures it.

    The Default netclass clearance is set to `probe_mm` and the DRC's clearance violations
    report the actual spacings; the smallest one wins. None when nothing is closer than the
    probe (the caller then uses the probe value).
    """
    from pcbdata.curation.projectfile import dumps_project, with_default_clearance

    probe = with_default_clearance(project, probe_mm)
    path = _stage(os.path.join(work, "probe"), board_bytes, dumps_project(probe))
    from pcbdata.kicad.drc_report import parse_drc_report

    best = None
    for violation in parse_drc_report(_drc(path, seed)).violations:
        if violation.type != "clearance" or violation.severity == "excluded":
            continue
        match = _ACTUAL.search(violation.message)
        if match and len(violation.nets) >= 2:
            actual = float(match.group(1))
            if actual > 0 and (best is None or actual < best):
                best = actual
    return best


def _items(board):
    """Every item whose UUID orders the saved file, in a deterministic (file) order."""
    for fp in board.GetFootprints():
        yield fp
        yield from fp.Pads()
        yield from fp.GraphicalItems()
        yield from fp.Zones()
    yield from board.GetDrawings()
    yield from board.Zones()
    yield from board.GetTracks()


def dedupe_uuids(board) -> int:
    """Makes every UUID unique; returns how many were changed.

    Legacy boards often give many footprints the same time stamp (e.g. 0), which becomes the
    same UUID. KiCad's writer orders items by UUID and breaks ties by memory address, so such
    a board would be saved in a different order from run to run. Each repeat of a UUID is
    incremented (KIID.Increment, in file order) until it is unused: deterministic, and only
    the UUIDs change.
    """
    items = list(_items(board))
    used = {item.m_Uuid.AsString() for item in items}
    seen: set[str] = set()
    changed = 0
    for item in items:
        uid = item.m_Uuid.AsString()
        if uid in seen:
            while item.m_Uuid.AsString() in used:
                item.m_Uuid.Increment()
            uid = item.m_Uuid.AsString()
            used.add(uid)
            changed += 1
        seen.add(uid)
    return changed


def _facts(board) -> dict:
    pcbnew = _pcbnew()
    layers = board.GetCopperLayerCount()
    return {
        "components": len(board.GetFootprints()),
        "copper_layers": int(layers),
        "board_pads": sum(len(fp.Pads()) for fp in board.GetFootprints()),
        "tracks": sum(1 for t in board.GetTracks() if t.Type() != pcbnew.PCB_VIA_T),
        "vias": sum(1 for t in board.GetTracks() if t.Type() == pcbnew.PCB_VIA_T),
        "zones": len(board.Zones()),
        "kicad_nets": int(board.GetNetCount()),
    }


_WARM = False
_WARM_BOARD = """(kicad_pcb (version 20171130) (host pcbnew "(5.1.12)")
  (general (thickness 1.6))
  (layers (0 F.Cu signal) (31 B.Cu signal) (44 Edge.Cuts user))
  (net 0 "") (net 1 N1)
  (net_class Default "default" (clearance 0.2) (trace_width 0.25) (add_net N1))
  (module P1 (layer F.Cu) (tedit 0) (tstamp 0) (at 5 5)
    (fp_text reference P1 (at 0 0) (layer F.Fab) (effects (font (size 1 1) (thickness 0.15))))
    (pad 1 smd rect (at 0 0) (size 1 1) (layers F.Cu) (net 1 N1)))
  (module P2 (layer F.Cu) (tedit 0) (tstamp 0) (at 15 5)
    (pad 1 smd rect (at 0 0) (size 1 1) (layers F.Cu) (net 1 N1)))
  (segment (start 5 5) (end 15 5) (width 0.25) (layer F.Cu) (net 1))
  (gr_line (start 0 0) (end 20 0) (layer Edge.Cuts) (width 0.05))
  (gr_line (start 20 0) (end 20 10) (layer Edge.Cuts) (width 0.05))
  (gr_line (start 20 10) (end 0 10) (layer Edge.Cuts) (width 0.05))
  (gr_line (start 0 10) (end 0 0) (layer Edge.Cuts) (width 0.05))
)
"""


def warm_up(compat: dict) -> None:
    """Runs the whole pipeline once on a tiny board in a fresh worker.

    KiCad initialises some objects lazily on first use, and that draws UUIDs from the seeded
    generator; without this, the first board a worker handles would get different UUIDs
    than the same board handled later (and a resumed build would not be byte-identical).
    """
    global _WARM
    if _WARM:
        return
    _WARM = True
    folder = tempfile.mkdtemp(prefix="pcbdata-d3-warm-")
    try:
        path = os.path.join(folder, "warm.kicad_pcb")
        with open(path, "w", encoding="utf-8") as handle:
            handle.write(_WARM_BOARD)
        process_board(path, 1, compat)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def check_project(project: dict, skip_checks) -> dict:
    """The project the revalidation DRC runs with: `project` with every check of
    `skip_checks` whose severity there is "warning" or "ignore" set to "ignore".

    Only error-severity violations and unconnected items decide whether a board is kept, so
    skipping warning-only checks (silk, text, library parity, ...) cannot change a verdict;
    it halves the DRC time. A check the project makes an error is always run.
    """
    import copy

    out = copy.deepcopy(project)
    severities = out.setdefault("board", {}).setdefault("design_settings", {}).setdefault(
        "rule_severities", {})
    for name in skip_checks:
        if severities.get(name, "error") in ("warning", "ignore"):  # absent: run it
            severities[name] = "ignore"
    return out


def process_board(source_path: str, seed: int, compat: dict, keep: dict | None = None) -> dict:
    """Upgrades, patches, revalidates and strips one source board.

    `keep` is the recipe's `[keep]` table: its skip list shapes the revalidation DRC, and a
    board its thresholds reject stops after the DRC (stage `drc`, no bare board: it is never
    written). Without it (the warm-up) every step runs.

    Returns plain data: `stage` (the step reached or failed at: load, upgrade, compat, drc,
    bare, done), `error`, the produced files as bytes (`files`: board, project, reference),
    the DRC report (`drc`, `DrcReport.to_dict()`), hashes around the compatibility pass and
    board facts. Raises nothing for a bad board: the failure is in the result.
    """
    from pcbdata.curation.build import is_kept
    from pcbdata.curation.projectfile import (default_clearance, dumps_project,
                                              patch_project)
    from pcbdata.kicad.drc_report import parse_drc_report

    skip_checks = (keep or {}).get("skip_warning_checks", ())

    pcbnew = _pcbnew()
    warm_up(compat)
    result: dict = {"stage": "load", "error": "", "timings": {}}
    work = tempfile.mkdtemp(prefix="pcbdata-d3-")
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        result["timings"][name] = round(now - clock, 3)
        clock = now

    try:
        src = os.path.join(work, "source.kicad_pcb")
        shutil.copyfile(source_path, src)
        try:
            board = _load(src, seed)
        except Exception as exc:  # noqa: BLE001
            result["error"] = f"load: {exc}"
            return result
        if board.GetFootprints() is None:
            result["error"] = "load: board has no footprint list"
            return result
        lap("load")

        result["stage"] = "upgrade"
        result["uuids_fixed"] = dedupe_uuids(board)
        up_dir = os.path.join(work, "upgraded")
        os.makedirs(up_dir)
        up_board = os.path.join(up_dir, BOARD)
        if not pcbnew.SaveBoard(up_board, board):
            result["error"] = "upgrade: KiCad could not save the board"
            return result
        result["facts"] = _facts(board)
        del board
        up_project = os.path.join(up_dir, PROJECT)
        if not os.path.isfile(up_project):
            result["error"] = "upgrade: KiCad saved no project file"
            return result
        with open(up_board, "rb") as handle:
            board_bytes = handle.read()
        with open(up_project, encoding="utf-8") as handle:
            project = json.load(handle)
        lap("upgrade")

        result["stage"] = "compat"
        before = hashlib.sha256(board_bytes).hexdigest()
        spacing = None
        clearance = default_clearance(project)
        if not clearance:
            spacing = min_copper_spacing(board_bytes, project, work, seed,
                                         float(compat["spacing_probe_mm"]))
            if spacing is None:
                spacing = float(compat["spacing_probe_mm"])
        patched = patch_project(project, compat, spacing)
        project_text = dumps_project(patched)
        check_path = _stage(os.path.join(work, "check"), board_bytes,
                            dumps_project(check_project(patched, skip_checks)))
        after = _sha(check_path)
        result["compat"] = {"board_sha256_before": before, "board_sha256_after": after,
                            "board_identical": before == after,
                            "stored_clearance": clearance, "observed_spacing": spacing}
        if before != after:
            result["error"] = "compat: the board file changed during the project pass"
            return result
        lap("compat")

        result["stage"] = "drc"
        try:
            bare = _load(check_path, seed)  # checked, then stripped into the bare board
            report = parse_drc_report(board_drc_text(bare, check_path))
        except Exception as exc:  # noqa: BLE001
            result["error"] = f"drc: {exc}"
            return result
        result["drc"] = report.to_dict()
        lap("drc")
        if keep is not None and not is_kept(report, keep):
            return result

        result["stage"] = "bare"
        for item in list(bare.GetTracks()):
            bare.Delete(item)
        bare_dir = os.path.join(work, "bare")
        os.makedirs(bare_dir)
        bare_path = os.path.join(bare_dir, BOARD)
        if not pcbnew.SaveBoard(bare_path, bare, True):
            result["error"] = "bare: KiCad could not save the bare board"
            return result
        del bare
        with open(os.path.join(bare_dir, PROJECT), "w", encoding="utf-8") as handle:
            handle.write(project_text)
        try:
            reloaded = _load(bare_path, seed)  # the task must load as it ships
        except Exception as exc:  # noqa: BLE001
            result["error"] = f"bare: the bare board does not load again ({exc})"
            return result
        result["bare_facts"] = _facts(reloaded)
        del reloaded
        with open(bare_path, "rb") as handle:
            bare_bytes = handle.read()
        lap("bare")
        result["files"] = {"board.kicad_pcb": bare_bytes,
                           "board.kicad_pro": project_text.encode("utf-8"),
                           "reference.kicad_pcb": board_bytes}
        result["stage"] = "done"
        return result
    finally:
        _unload_projects()
        shutil.rmtree(work, ignore_errors=True)


def kicad_version() -> str:
    return str(_pcbnew().Version())

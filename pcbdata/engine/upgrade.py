"""D3 per-board engine work: KiCad 9 upgrade, project compatibility pass, DRC, bare board.

Runs inside `EnginePool` worker processes only (one task per source board, see
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

BOARD = "board.kicad_pcb"
PROJECT = "board.kicad_pro"
REFERENCE = "reference.kicad_pcb"

_ACTUAL = re.compile(r"actual ([0-9.]+) mm")


def _pcbnew():
    import pcbnew  # only engine workers import KiCad

    return pcbnew


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
    pcbnew = _pcbnew()
    board = _load(board_path, seed)
    report = os.path.join(os.path.dirname(board_path), "drc.rpt")
    if not pcbnew.WriteDRCReport(board, report, pcbnew.EDA_UNITS_MM, True):
        raise RuntimeError("KiCad DRC did not produce a report")
    with open(report, encoding="utf-8", errors="replace") as handle:
        return handle.read()


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
    from pcbdata.engine.drc_report import parse_drc_report

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


def process_board(source_path: str, seed: int, compat: dict) -> dict:
    """Upgrades, patches, revalidates and strips one source board.

    Returns plain data: `stage` (the step reached or failed at: load, upgrade, compat, drc,
    bare, done), `error`, the produced files as bytes (`files`: board, project, reference),
    the DRC report (`drc`, `DrcReport.to_dict()`), hashes around the compatibility pass and
    board facts. Raises nothing for a bad board: the failure is in the result.
    """
    from pcbdata.curation.projectfile import (default_clearance, dumps_project,
                                              patch_project)
    from pcbdata.engine.drc_report import parse_drc_report

    pcbnew = _pcbnew()
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
        check_path = _stage(os.path.join(work, "check"), board_bytes, project_text)
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
            report = parse_drc_report(_drc(check_path, seed))
        except Exception as exc:  # noqa: BLE001
            result["error"] = f"drc: {exc}"
            return result
        result["drc"] = report.to_dict()
        lap("drc")

        result["stage"] = "bare"
        bare = _load(check_path, seed)
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
        reloaded = _load(bare_path, seed)  # the task must load as it ships
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

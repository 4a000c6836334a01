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

import json
import os
import re
import shutil
import tempfile
import time
from typing import Any

from pcbdata.core.hashing import sha256_bytes, sha256_file
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, REFERENCE_FILE
from pcbdata.kicad.basics import board_drc_text
from pcbdata.kicad.basics import pcbnew_module as _pcbnew
from pcbdata.kicad.drc_report import parse_drc_report
from pcbdata.kicad.projectfile import (
    check_project,
    default_clearance,
    dumps_project,
    patch_project,
    with_default_clearance,
)

_ACTUAL = re.compile(r"actual ([0-9.]+) mm")


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
    with open(os.path.join(folder, BOARD_FILE), "wb") as handle:
        handle.write(board_bytes)
    with open(os.path.join(folder, PROJECT_FILE), "w", encoding="utf-8") as handle:
        handle.write(project_text)
    return os.path.join(folder, BOARD_FILE)


def min_copper_spacing(board_bytes: bytes, project: dict, work: str, seed: int,
                       probe_mm: float) -> float | None:
    """Smallest positive spacing between copper of different nets, as KiCad's DRC measures it.

    The Default netclass clearance is set to `probe_mm` and the DRC's clearance violations
    report the actual spacings; the smallest one wins. None when nothing is closer than the
    probe (the caller then uses the probe value).
    """
    probe = with_default_clearance(project, probe_mm)
    path = _stage(os.path.join(work, "probe"), board_bytes, dumps_project(probe))
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


def process_board(source_path: str, seed: int, compat: dict, keep: dict | None = None) -> dict:
    """Upgrades, patches, revalidates and strips one source board.

    The policy is data: `compat` is the recipe's `[compat]` table (see
    `pcbdata.kicad.projectfile.patch_project`), `keep` its `[keep]` table (`max_errors`,
    `max_unconnected`, `skip_warning_checks`), both as plain dicts. The skip list shapes the
    revalidation DRC, and a board the thresholds reject stops after the DRC (stage `drc`, no
    bare board: it is never written). Without `keep` (the warm-up) every step runs.

    Returns plain data: `stage` (the step reached or failed at: load, upgrade, compat, drc,
    bare, done), `error`, the produced files as bytes (`files`: board, project, reference),
    the DRC report (`drc`, `DrcReport.to_dict()`), hashes around the compatibility pass and
    board facts. Raises nothing for a bad board: the failure is in the result.
    """
    warm_up(compat)
    job = _BoardJob(source_path, seed, compat, keep)
    try:
        return job.run()
    finally:
        _unload_projects()
        shutil.rmtree(job.work, ignore_errors=True)


def upgraded_board(source_path: str, seed: int) -> bytes:
    """The file KiCad 9 saves from `source_path` (D3's step 1 alone: load, fix duplicate
    UUIDs, save): legacy boards measured from their own text lose what the old format spells
    differently (arcs by centre and angle). Raises ValueError naming the failed step."""
    job = _BoardJob(source_path, seed, {}, None)
    try:
        for name, step in (("load", job._load), ("upgrade", job._upgrade)):
            try:
                step()
            except _Failed as exc:
                raise ValueError(f"{name}: {exc}") from None
        return job.board_bytes
    finally:
        _unload_projects()
        shutil.rmtree(job.work, ignore_errors=True)


class _Failed(Exception):
    """A step failed; the message (after the step's name) is the board's recorded reason."""


class _BoardJob:
    """The steps of `process_board` on one board, each a method; a step raises `_Failed`."""

    def __init__(self, source_path: str, seed: int, compat: dict, keep: dict | None):
        self.source_path, self.seed, self.compat, self.keep = source_path, seed, compat, keep
        self.result: dict[str, Any] = {"stage": "load", "error": "", "timings": {}}
        self.work = tempfile.mkdtemp(prefix="pcbdata-d3-")
        self.board: Any = None   # the loaded board, until saved upgraded
        self.bare: Any = None    # the board the DRC checked, stripped into the bare board
        self.board_bytes = b""   # the upgraded board file: the reference
        self.upgraded_path = ""  # where KiCad's upgraded save wrote it (with its project)
        self.project: dict = {}  # the project KiCad saved with it
        self.project_text = ""   # the patched project, as shipped
        self.check_path = ""

    def run(self) -> dict:
        steps = (("load", self._load), ("upgrade", self._upgrade), ("compat", self._compat),
                 ("drc", self._drc), ("bare", self._bare))
        clock = time.perf_counter()
        try:
            for name, step in steps:
                self.result["stage"] = name
                go_on = step()
                now = time.perf_counter()
                self.result["timings"][name] = round(now - clock, 3)
                clock = now
                if go_on is False:
                    return self.result
        except _Failed as exc:
            self.result["error"] = f"{self.result['stage']}: {exc}"
            return self.result
        self.result["stage"] = "done"
        return self.result

    def _load(self) -> None:
        src = os.path.join(self.work, "source.kicad_pcb")
        shutil.copyfile(self.source_path, src)
        try:
            self.board = _load(src, self.seed)
        except Exception as exc:  # noqa: BLE001
            raise _Failed(str(exc)) from None
        if self.board.GetFootprints() is None:
            raise _Failed("board has no footprint list")

    def _upgrade(self) -> None:
        self.result["uuids_fixed"] = dedupe_uuids(self.board)
        up_dir = os.path.join(self.work, "upgraded")
        os.makedirs(up_dir)
        up_board = os.path.join(up_dir, BOARD_FILE)
        if not _pcbnew().SaveBoard(up_board, self.board):
            raise _Failed("KiCad could not save the board")
        self.result["facts"] = _facts(self.board)
        self.board = None
        up_project = os.path.join(up_dir, PROJECT_FILE)
        if not os.path.isfile(up_project):
            raise _Failed("KiCad saved no project file")
        self.upgraded_path = up_board
        with open(up_board, "rb") as handle:
            self.board_bytes = handle.read()
        with open(up_project, encoding="utf-8") as handle:
            self.project = json.load(handle)

    def _compat(self) -> None:
        """SPEC 3 step 2: patches the project KiCad saved beside the upgraded board, and checks
        that the board file on disk is the same bytes after the pass as KiCad wrote them (the
        reference ships as read after the pass)."""
        before = sha256_file(self.upgraded_path)
        spacing = None
        clearance = default_clearance(self.project)
        if not clearance:
            probe = float(self.compat["spacing_probe_mm"])
            spacing = min_copper_spacing(self.board_bytes, self.project, self.work, self.seed,
                                         probe)
            if spacing is None:
                spacing = probe
        patched = patch_project(self.project, self.compat, spacing)
        self.project_text = dumps_project(patched)
        self.board_bytes = self._patch_beside_board()
        after = sha256_bytes(self.board_bytes)
        skip_checks = (self.keep or {}).get("skip_warning_checks", ())
        self.check_path = _stage(os.path.join(self.work, "check"), self.board_bytes,
                                 dumps_project(check_project(patched, skip_checks)))
        self.result["compat"] = {"board_sha256_before": before, "board_sha256_after": after,
                                 "board_identical": before == after,
                                 "stored_clearance": clearance, "observed_spacing": spacing}
        if before != after:
            raise _Failed("the board file changed during the project pass")

    def _patch_beside_board(self) -> bytes:
        """Writes the patched project over the one KiCad saved beside the upgraded board;
        returns the board file as it is on disk afterwards."""
        folder = os.path.dirname(self.upgraded_path)
        with open(os.path.join(folder, PROJECT_FILE), "w", encoding="utf-8") as handle:
            handle.write(self.project_text)
        with open(self.upgraded_path, "rb") as handle:
            return handle.read()

    def _drc(self) -> bool:
        """Checks the board; False (stop) when the recipe's thresholds reject it."""
        try:
            self.bare = _load(self.check_path, self.seed)  # checked, then stripped
            report = parse_drc_report(board_drc_text(self.bare, self.check_path))
        except Exception as exc:  # noqa: BLE001
            raise _Failed(str(exc)) from None
        self.result["drc"] = report.to_dict()
        if self.keep is None:
            return True
        limit = self.keep.get("max_unconnected")
        return report.within(int(self.keep["max_errors"]), None if limit is None else int(limit))

    def _bare(self) -> None:
        for item in list(self.bare.GetTracks()):
            self.bare.Delete(item)
        bare_dir = os.path.join(self.work, "bare")
        os.makedirs(bare_dir)
        bare_path = os.path.join(bare_dir, BOARD_FILE)
        if not _pcbnew().SaveBoard(bare_path, self.bare, True):
            raise _Failed("KiCad could not save the bare board")
        self.bare = None
        with open(os.path.join(bare_dir, PROJECT_FILE), "w", encoding="utf-8") as handle:
            handle.write(self.project_text)
        try:
            reloaded = _load(bare_path, self.seed)  # the task must load as it ships
        except Exception as exc:  # noqa: BLE001
            raise _Failed(f"the bare board does not load again ({exc})") from None
        self.result["bare_facts"] = _facts(reloaded)
        del reloaded
        with open(bare_path, "rb") as handle:
            bare_bytes = handle.read()
        self.result["files"] = {BOARD_FILE: bare_bytes,
                                PROJECT_FILE: self.project_text.encode("utf-8"),
                                REFERENCE_FILE: self.board_bytes}

"""Everything that calls KiCad's `pcbnew` module. Runs inside engine worker processes only.

`pcbnew` can crash or hang on some boards and some edits damage the process, so these
functions are called through `pcbdata.kicad.pool.KicadPool`, never in the main process.
"""
from __future__ import annotations

import os
import shutil
import tempfile


def pcbnew_module():
    """KiCad's `pcbnew`, imported lazily: only engine workers import KiCad."""
    import pcbnew

    return pcbnew

def stage_with_project(board_path: str, project: str, custom_rules: str | None, folder: str,
                       stem: str = "checked") -> str:
    """Copies a board next to copies of a project (and custom rules) under one stem in
    `folder`, so that KiCad loads the board with exactly those rules; returns the board copy."""
    staged = os.path.join(folder, f"{stem}.kicad_pcb")
    shutil.copyfile(board_path, staged)
    shutil.copyfile(project, os.path.join(folder, f"{stem}.kicad_pro"))
    if custom_rules is not None:
        shutil.copyfile(custom_rules, os.path.join(folder, f"{stem}.kicad_dru"))
    return staged

def kicad_version() -> str:
    return str(pcbnew_module().Version())

def load_board(path: str):
    """Loads a board (and its project file, which carries the design rules)."""
    pcbnew = pcbnew_module()
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such board file")
    board = pcbnew.LoadBoard(path)
    if board is None:
        raise ValueError(f"{path}: KiCad could not load the board")
    return board

def board_drc_text(board, where: str = "board") -> str:
    """KiCad's DRC (all track errors) of a loaded board under the project it was loaded with."""
    pcbnew = pcbnew_module()
    with tempfile.TemporaryDirectory(prefix="pcbdata-drc-") as tmp:
        report = os.path.join(tmp, "drc.rpt")
        if not pcbnew.WriteDRCReport(board, report, pcbnew.EDA_UNITS_MM, True):
            raise RuntimeError(f"{where}: KiCad DRC did not produce a report")
        # Legacy boards can hold names that are not UTF-8; the report must still parse.
        with open(report, encoding="utf-8", errors="replace") as handle:
            return handle.read()

def drc_text(path: str) -> str:
    """Runs KiCad's DRC on a board file with its own project rules; returns the report text."""
    return board_drc_text(load_board(path), path)

def drc(path: str, project: str | None = None, custom_rules: str | None = None) -> dict:
    """DRC of a board file as a plain-data report (see `drc_report.DrcReport.to_dict`).

    KiCad takes the rules from the `.kicad_pro`/`.kicad_dru` that share the board file's stem.
    With `project` (and `custom_rules`) given, the board is checked under those rules instead:
    a copy of it is checked next to copies of them, so that e.g. `reference.kicad_pcb` or a
    submitted board is judged by its instance's `board.kicad_pro`, never by files of its own.
    """
    from pcbdata.kicad.drc_report import parse_drc_report

    if project is None:
        return parse_drc_report(drc_text(path)).to_dict()
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such board file")
    with tempfile.TemporaryDirectory(prefix="pcbdata-rules-") as tmp:
        board = stage_with_project(path, project, custom_rules, tmp)
        return parse_drc_report(drc_text(board)).to_dict()

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

#: Where DRC reports are written first: KiCad writes one file per DRC, and on tmpfs that costs
#: about 1 ms less per call than on a disk (the routing environment runs a DRC per step).
FAST_REPORT_DIR = "/dev/shm"
#: KiCad's last line of a whole report: a report cut short (a full disk) must not be counted.
REPORT_END = "** End of Report **"


def _report_dirs() -> list[str | None]:
    """Folders to write DRC reports in, first choice first (None: the default temp folder)."""
    fast = FAST_REPORT_DIR
    return [fast, None] if os.path.isdir(fast) and os.access(fast, os.W_OK | os.X_OK) else [None]


def _drc_report_in(board, folder: str | None) -> str | None:
    """The DRC report text of `board` written in a new folder under `folder`; None when KiCad
    wrote no whole report there."""
    pcbnew = pcbnew_module()
    with tempfile.TemporaryDirectory(prefix="pcbdata-drc-", dir=folder) as tmp:
        report = os.path.join(tmp, "drc.rpt")
        if not pcbnew.WriteDRCReport(board, report, pcbnew.EDA_UNITS_MM, True):
            return None
        # Legacy boards can hold names that are not UTF-8; the report must still parse.
        with open(report, encoding="utf-8", errors="replace") as handle:
            text = handle.read()
    return text if is_whole_report(text) else None


def is_whole_report(text: str) -> bool:
    """Whether a DRC report ends as KiCad ends every report it finished writing."""
    return text.rstrip().endswith(REPORT_END)


def board_drc_text(board, where: str = "board") -> str:
    """KiCad's DRC (all track errors) of a loaded board under the project it was loaded with."""
    for folder in _report_dirs():
        try:
            text = _drc_report_in(board, folder)
        except OSError:
            text = None
        if text is not None:
            return text
    raise RuntimeError(f"{where}: KiCad DRC did not produce a whole report")

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

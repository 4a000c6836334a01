"""Everything that calls KiCad's `pcbnew` module. Runs inside engine worker processes only.

`pcbnew` can crash or hang on some boards and some edits damage the process, so these
functions are called through `pcbdata.engine.pool.EnginePool`, never in the main process.
"""
from __future__ import annotations

import os
import tempfile


def _pcbnew():
    import pcbnew  # imported lazily: only engine workers need KiCad

    return pcbnew


def kicad_version() -> str:
    return str(_pcbnew().Version())


def load_board(path: str):
    """Loads a board (and its project file, which carries the design rules)."""
    pcbnew = _pcbnew()
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such board file")
    board = pcbnew.LoadBoard(path)
    if board is None:
        raise ValueError(f"{path}: KiCad could not load the board")
    return board


def drc_text(path: str) -> str:
    """Runs KiCad's DRC on a board file with its own project rules; returns the report text."""
    pcbnew = _pcbnew()
    board = load_board(path)
    with tempfile.TemporaryDirectory(prefix="pcbdata-drc-") as tmp:
        report = os.path.join(tmp, "drc.rpt")
        if not pcbnew.WriteDRCReport(board, report, pcbnew.EDA_UNITS_MM, True):
            raise RuntimeError(f"{path}: KiCad DRC did not produce a report")
        with open(report, encoding="utf-8") as handle:
            return handle.read()


def drc(path: str) -> dict:
    """DRC of a board file as a plain-data report (see `drc_report.DrcReport.to_dict`)."""
    from pcbdata.engine.drc_report import parse_drc_report

    return parse_drc_report(drc_text(path)).to_dict()

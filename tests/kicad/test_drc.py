"""In-process DRC through the engine: real KiCad, each board with its own project rules."""
from pcbdata.kicad import DrcReport, parse_drc_report
from pcbdata.model.board import Board, Pad, Rules, mm_to_nm
from pcbdata.testing.sets import write_board


def _two_pads(clearance_mm: float) -> Board:
    rules = Rules(clearance=mm_to_nm(clearance_mm), track_width=mm_to_nm(0.2),
                  edge_clearance=mm_to_nm(0.2), via_diameter=mm_to_nm(0.6), via_drill=mm_to_nm(0.3))
    pads = [Pad(x=mm_to_nm(10), y=mm_to_nm(10), net="A", kind="smd_rect", size=mm_to_nm(1)),
            Pad(x=mm_to_nm(12), y=mm_to_nm(10), net="B", kind="smd_rect", size=mm_to_nm(1))]
    return Board(width=mm_to_nm(30), height=mm_to_nm(30), rules=rules, pads=pads, uuid_seed="t")


def test_each_board_is_checked_with_its_own_project_in_a_long_lived_worker(kicad_pool, tmp_path):
    # The pads are 1 mm apart: fine at clearance 0.5, a violation at clearance 1.5.
    loose = write_board(tmp_path / "loose", _two_pads(0.5))
    tight = write_board(tmp_path / "tight", _two_pads(1.5))
    paths = [(str(p),) for p in (loose, tight, loose, tight, loose, tight)]
    outcomes = sorted(kicad_pool.map("pcbdata.kicad.basics:drc", paths), key=lambda o: o.index)
    counts = [DrcReport.from_dict(o.value).counts_by_type(include_unconnected=False)
              for o in outcomes]
    assert counts == [{}, {"clearance": 1}] * 3


def test_report_parser_reads_types_severities_nets_and_sections():
    text = """** Drc report for /x/board.kicad_pcb **
** Created on 2026-11-22 04:21:41 **

** Found 2 DRC violations **
[items_not_allowed]: Items not allowed (rule 'single_layer_routing')
    Rule: single_layer_routing; error
    @(1.5000 mm, 1.5000 mm): Track [NET1] on B.Cu, length 38.5000 mm
[track_dangling]: Track has unconnected end
    Local override; warning
    @(1.5000 mm, 1.5000 mm): Track [<no net>] on B.Cu, length 38.5000 mm

** Found 1 unconnected pads **
[unconnected_items]: Missing connection between items
    Local override; error
    @(3.5000 mm, 1.5000 mm): Pad 1 [NET2] of P3 on B.Cu
    @(21.5000 mm, 21.5000 mm): PTH pad 1 [NET2] of P4

** Found 0 Footprint errors **

** End of Report **
"""
    report = parse_drc_report(text)
    assert report.declared_counts == {"violations": 2, "unconnected": 1, "footprint": 0}
    first, second, third = report.violations
    assert (first.type, first.severity, first.rule, first.nets) == (
        "items_not_allowed", "error", "Rule: single_layer_routing", ["NET1"])
    assert (second.severity, second.nets) == ("warning", [])
    assert (third.section, third.nets, len(third.items)) == ("unconnected", ["NET2"], 2)
    assert report.counts_by_type() == {"items_not_allowed": 1, "track_dangling": 1,
                                       "unconnected_items": 1}
    assert DrcReport.from_dict(report.to_dict()) == report


def test_parser_rejects_text_that_is_not_a_report():
    try:
        parse_drc_report("hello")
    except ValueError as exc:
        assert "not a KiCad DRC report" in str(exc)
    else:
        raise AssertionError("expected ValueError")


def drc_with_report_dir(path: str, folder: str) -> dict:
    """Worker task: `basics.drc` with KiCad's reports written first under `folder`."""
    from pcbdata.kicad import basics

    basics.FAST_REPORT_DIR = folder
    return basics.drc(path)


def test_reports_go_to_the_fast_folder_or_else_the_default_one(kicad_pool, tmp_path):
    tight = str(write_board(tmp_path / "tight", _two_pads(1.5)))
    (tmp_path / "a-file").write_text("not a folder")
    folders = [tmp_path / "fast", tmp_path / "missing", tmp_path / "a-file"]
    (tmp_path / "fast").mkdir()
    jobs = [(tight, str(folder)) for folder in folders]
    outcomes = sorted(kicad_pool.map("tests.kicad.test_drc:drc_with_report_dir", jobs),
                      key=lambda o: o.index)
    assert all(o.ok for o in outcomes), [o.error for o in outcomes]
    counts = [DrcReport.from_dict(o.value).counts_by_type(include_unconnected=False)
              for o in outcomes]
    assert counts == [{"clearance": 1}] * 3
    assert list((tmp_path / "fast").iterdir()) == []  # each report's folder is removed


def test_a_report_cut_short_is_not_taken_for_a_whole_one(kicad_pool, tmp_path):
    from pcbdata.kicad.basics import REPORT_END, is_whole_report

    tight = str(write_board(tmp_path / "tight", _two_pads(1.5)))
    outcome = next(iter(kicad_pool.map("pcbdata.kicad.basics:drc_text", [(tight,)])))
    text = outcome.value
    assert is_whole_report(text) and text.rstrip().endswith(REPORT_END)
    cut = text[: text.index("** Found 0 Footprint errors **")]
    assert not is_whole_report(cut)
    parse_drc_report(cut)  # the parser alone would take it: the check is what refuses it

"""The dropped PCBench boards of a tier's size (`pcbdata.realism.external`): real
KiCad upgrades of the CI subset's boards, measured as D3's own."""
from __future__ import annotations

import csv
import shutil

import pytest

from pcbdata.realism import external as external_boards
from pcbdata.realism.external import (
    DROPPED_FATES,
    UPGRADE_TASK,
    dropped_boards,
    external_sample,
    pads_matched_weights,
    tier_pad_range,
)
from pcbdata.realism.statistics import BoardStatistics, board_statistics


def _report(d3_root):
    with open(d3_root / "curation_report.csv", newline="", encoding="utf-8") as handle:
        return {row["name"]: row for row in csv.DictReader(handle)}


@pytest.fixture(scope="module")
def sample_a(real_subset, tmp_path_factory):
    work = tmp_path_factory.mktemp("external")
    lines: list[str] = []
    sample = external_sample(real_subset["out"], real_subset["source"], "A", work,
                             progress=lines.append)
    return {"sample": sample, "work": work, "lines": lines}


def test_every_dropped_board_is_measured_and_sorted_by_size(real_subset, sample_a):
    sample = sample_a["sample"]
    report = _report(real_subset["out"])
    dropped = {name for name, row in report.items() if row["fate"] in DROPPED_FATES}
    assert dropped and set(dropped_boards(real_subset["out"])) == dropped
    assert not sample.failures
    assert len(sample.boards) + sample.outside == len(dropped)
    low, high = sample.pad_range
    assert (low, high) == tier_pad_range(real_subset["out"], "A")
    assert sample.boards, "the subset's smallest boards include dropped ones of tier A's size"
    for board in sample.boards:
        assert board.name in dropped and low <= board.statistics.pads <= high
        assert board.path == sample_a["work"] / board.name / "board.kicad_pcb"
    assert sample_a["lines"][-1].startswith(f"upgraded {len(dropped)}/{len(dropped)}")


def test_an_upgraded_board_measures_as_the_d3_build_s_own(real_subset, kicad_pool, tmp_path):
    """The upgrade task is D3's step 1: on kept boards whose legacy text measures another
    outline (arcs by centre and angle), its file measures exactly as the board D3 ships."""
    report = _report(real_subset["out"])
    checked = 0
    for name, row in sorted(report.items(), key=lambda item: item[1]["board_id"]):
        if row["fate"] != "kept":
            continue
        source = real_subset["source"] / "PCBs" / name / "processed.kicad_pcb"
        shipped = board_statistics(next(real_subset["out"].glob(
            f"d3-*/full/{row['board_id']}/board.kicad_pcb")))
        if _same_density(board_statistics(source), shipped):
            continue
        upgraded = tmp_path / "upgraded.kicad_pcb"
        upgraded.write_bytes(kicad_pool.call(UPGRADE_TASK, str(source), 0))
        assert board_statistics(upgraded) == shipped, name
        checked += 1
        if checked == 2:
            return
    pytest.fail("no kept board of the subset whose legacy text measures another density")


def _same_density(a, b) -> bool:
    if a.pad_density is None or b.pad_density is None:
        return a.pad_density == b.pad_density
    return abs(a.pad_density - b.pad_density) <= 1e-9 * b.pad_density


def test_a_rerun_reuses_the_upgraded_files(real_subset, sample_a, monkeypatch):
    def no_kicad(*args, **kwargs):
        raise AssertionError("KiCad started although every board was upgraded already")

    monkeypatch.setattr(external_boards, "KicadPool", no_kicad)
    again = external_sample(real_subset["out"], real_subset["source"], "A", sample_a["work"])
    assert [b.name for b in again.boards] == [b.name for b in sample_a["sample"].boards]
    assert [b.statistics for b in again.boards] == sample_a["sample"].statistics


def test_a_changed_or_missing_source_is_refused_with_its_reason(real_subset, tmp_path):
    names = sorted(dropped_boards(real_subset["out"]))
    changed, missing = names[0], names[1]
    source = tmp_path / "pcbench"
    (source / "PCBs").mkdir(parents=True)
    for folder in (real_subset["source"] / "PCBs").iterdir():
        if folder.name in (changed, missing):
            shutil.copytree(folder, source / "PCBs" / folder.name)
        else:
            (source / "PCBs" / folder.name).symlink_to(folder.resolve())
    board = source / "PCBs" / changed / "processed.kicad_pcb"
    board.write_bytes(board.read_bytes() + b"\n")
    (source / "PCBs" / missing / "processed.kicad_pcb").unlink()
    sample = external_sample(real_subset["out"], source, "B", tmp_path / "work")
    assert sample.failures[changed].endswith("not the file D3's build saw (SHA-256 differs)")
    assert sample.failures[missing].endswith("processed.kicad_pcb: missing")
    assert len(sample.boards) + sample.outside + 2 == len(names)


def _pads(*counts: int) -> list[BoardStatistics]:
    return [BoardStatistics(nets=1, pads=n, components=1, layers=2, pads_per_net=(n,),
                            outline_area_mm2=None) for n in counts]


def test_the_weights_give_the_external_boards_the_calibration_half_s_pads():
    calibration = _pads(*range(10, 30))  # 20 boards, 4 a quintile
    external = _pads(10, 11, 12, 13, 14, 15, 28, 40)  # many small ones, one out of range
    weights = pads_matched_weights(calibration, external)
    assert weights[-1] == 0.0 and sum(weights) == pytest.approx(len(external))
    # quintiles 10-13, 14-17, 18-21, 22-25, 26-29: the three that hold external boards carry
    # equal weight (18-25 hold none)
    assert weights[:4] == pytest.approx([weights[0]] * 4)  # 10-13: one quintile, 4 boards
    assert weights[4] == pytest.approx(weights[5]) == pytest.approx(2 * weights[0])
    assert weights[6] == pytest.approx(4 * weights[0])  # the top quintile's only board
    assert pads_matched_weights([], external) == [0.0] * 8
    assert pads_matched_weights(_pads(20, 20), _pads(20, 21)) == [2.0, 0.0]


def test_not_a_pcbench_checkout_is_named(real_subset, tmp_path):
    with pytest.raises(FileNotFoundError, match="not a PCBench checkout \\(no PCBs/ folder\\)"):
        external_sample(real_subset["out"], tmp_path, "A", tmp_path / "work")
    assert not (tmp_path / "work").exists()


def test_not_a_d3_build_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="curation_report.csv: no curation report"):
        dropped_boards(tmp_path)
    (tmp_path / "curation_report.csv").write_text("board,reason\nx,y\n")
    with pytest.raises(ValueError, match="curation_report.csv: not a curation report "
                                         "\\(no column fate, name\\)"):
        dropped_boards(tmp_path)
    (tmp_path / "characteristics.csv").write_text("board_id,name,nets,components,pads,layers,"
                                                  "tier,in_test\n")
    with pytest.raises(ValueError, match="no board of tier A"):
        tier_pad_range(tmp_path, "A")


"""Router-found reference routings of `pcbdata build d2r --reference-agent` (real KiCad, d2r-a
test boards, about a second each to route): the references pass the build's KiCad check and
score CP 1; each is the board `pcbdata rollout` writes (DRC after every step) byte for byte; a
rebuild gives the same bytes; a build run again routes nothing it routed; boards
not completed or whose worker failed stay, with the reason; `eval --reference` scores the
boards that have one and counts the others; bad option values are one-line errors."""
from __future__ import annotations

import dataclasses
import json
import os
import shutil

import pytest

from pcbdata.cli import main
from pcbdata.core.tree import REFERENCE_FILE, reference_log_path

AGENT_FOR_TESTS = "tests.builds.agents_for_reference:GivesUpAndCrashes"


def _build(out, *args) -> int:
    return main(["build", "d2r", "--level", "a", "--splits", "test", "--count", "2",
                 "--workers", "2", "--out", str(out), *map(str, args)])


def _files(root) -> dict:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and ".pcbdata" not in p.parts}


def _config(root) -> dict:
    return json.loads((root / "manifest.json").read_text())["configs"]["d2r-a"]


@pytest.fixture(scope="module")
def routed(tmp_path_factory):
    """Two d2r-a test boards with references by the default agent, negotiated (both route at
    seed 0)."""
    out = tmp_path_factory.mktemp("routed") / "set"
    assert _build(out, "--reference-agent", "--reference-rollouts", "2") == 0
    return out


def test_references_are_kept_with_their_origin(routed):
    split = _config(routed)["splits"]["test"]
    assert split["reference_routing"] == {
        "agent": "negotiated", "rollouts": 2, "env_options": {"drc": "terminal", "max_steps": None},
        "env_version": 2, "boards": 2, "routed": 2, "not_completed": 0, "engine_failure": 0,
        "check_failed": 0}
    for board_id, board in split["boards"].items():
        origin = board["reference_routing"]
        assert origin["status"] == "routed" and origin["agent"] == "negotiated"
        assert origin["seed"] == 0 and origin["env_id"] == "pcbdata/Route-d2r-a-v2"
        assert origin["reason"] == "" and origin["package_version"]
        assert REFERENCE_FILE in board["files"]
        assert (routed / "d2r-a" / "test" / board_id / REFERENCE_FILE).is_file()
    assert main(["verify", str(routed)]) == 0


def test_references_pass_the_kicad_check(routed):
    from pcbdata.build.synthetic import check_problem
    from pcbdata.kicad import KicadPool
    from pcbdata.kicad.drc_report import DrcReport

    checked = [json.loads(line)["path"] for line in
               (routed / ".pcbdata" / "checks.jsonl").read_text().splitlines()]
    refs = sorted(routed.glob(f"d2r-a/test/*/{REFERENCE_FILE}"))
    assert len(refs) == 2 and all(str(p.relative_to(routed)) in checked for p in refs)
    with KicadPool(workers=1) as pool:  # and again here, independently of the build's log
        for path in refs:
            report = DrcReport.from_dict(pool.call(
                "pcbdata.kicad.basics:drc", str(path), str(path.parent / "board.kicad_pro"),
                str(path.parent / "board.kicad_dru")))
            assert not report.unconnected and check_problem(report, 0) is None, path


def test_a_reference_is_the_board_pcbdata_rollout_writes_with_a_drc_after_every_step(
        routed, tmp_path):
    """The build's rollouts run KiCad's DRC once, at the end; `pcbdata rollout` by default
    after every step. The agents do not read it: the same board, byte for byte."""
    runs = tmp_path / "runs"
    assert main(["rollout", str(routed), "--config", "d2r-a", "--split", "test", "--agent",
                 "negotiated", "--rollouts", "1", "--workers", "1", "--out", str(runs)]) == 0
    for board_id, board in _config(routed)["splits"]["test"]["boards"].items():
        assert board["reference_routing"]["seed"] == 0
        assert (runs / board_id / "0.kicad_pcb").read_bytes() == (
            routed / "d2r-a" / "test" / board_id / REFERENCE_FILE).read_bytes()


def test_a_rebuild_gives_the_same_bytes(routed, tmp_path):
    again = tmp_path / "again"
    assert _build(again, "--reference-agent", "--reference-rollouts", "2") == 0
    assert _files(again) == _files(routed)


def test_a_build_run_again_routes_only_what_it_had_not(routed, tmp_path, capsys):
    copy = tmp_path / "copy"
    shutil.copytree(routed, copy)
    manifest = (copy / "manifest.json").read_bytes()
    kept = copy / "d2r-a/test/board_00000" / REFERENCE_FILE
    stamp = kept.stat().st_mtime_ns
    # As if killed after routing board_00000: board_00001's result and the manifest are lost.
    log = reference_log_path(copy)
    log.write_text("".join(line + "\n" for line in log.read_text().splitlines()
                           if "board_00001" not in line))
    os.unlink(copy / "manifest.json")
    capsys.readouterr()
    assert _build(copy, "--reference-agent", "--reference-rollouts", "2") == 0
    out, err = capsys.readouterr()
    assert "references: 2 of 2 boards routed (1 kept from an earlier run)" in out
    assert "reference routing (negotiated, 2 rollouts): 1/1" in err
    assert kept.stat().st_mtime_ns == stamp
    assert (copy / "manifest.json").read_bytes() == manifest
    assert _build(copy, "--reference-agent", "--reference-rollouts", "2") == 0
    out, err = capsys.readouterr()
    assert "(2 kept from an earlier run)" in out and "reference routing (" not in err


def test_verify_names_a_reference_routing_stopped_before_its_end(routed, tmp_path, capsys):
    copy = tmp_path / "copy"
    shutil.copytree(routed, copy)
    # The manifest as the build writes it before routing, when board_00001 had no result yet
    # (its reference then routed, the build killed before the manifest was written again).
    manifest = json.loads((copy / "manifest.json").read_text())
    split = manifest["configs"]["d2r-a"]["splits"]["test"]
    board = split["boards"]["board_00001"]
    del board["reference_routing"], board["files"][REFERENCE_FILE]
    split["reference_routing"].update(boards=1, routed=1)
    (copy / "manifest.json").write_text(json.dumps(manifest))
    capsys.readouterr()
    assert main(["verify", str(copy)]) != 0
    out = capsys.readouterr()
    text = out.out + out.err
    assert "d2r-a/test: reference routing unfinished: 1 of 2 boards have no result yet" in text
    assert ("d2r-a/test/board_00001/reference.kicad_pcb: routed after the manifest was written"
            in text)
    assert "extra file" not in text
    assert _build(copy, "--reference-agent", "--reference-rollouts", "2") == 0
    assert main(["verify", str(copy)]) == 0


def test_a_build_without_the_option_drops_them(routed, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(routed, copy)
    assert _build(copy) == 0
    assert not list(copy.glob(f"d2r-a/test/*/{REFERENCE_FILE}"))
    assert "reference_routing" not in (copy / "manifest.json").read_text()
    assert main(["verify", str(copy)]) == 0


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    """Three boards: board_00000 routed, board_00001 not completed, board_00002's worker
    dies (the test agent), built with the library's options."""
    from pcbdata.build import SyntheticOptions, build_level
    from pcbdata.runners.reference import plan

    out = tmp_path_factory.mktemp("mixed") / "set"
    reference = dataclasses.replace(plan("scripted", 1), agent=AGENT_FOR_TESTS)
    options = SyntheticOptions(splits=["test"], count=3, workers=2, reference=reference)
    summary = build_level(out, "d2r", "a", options=options)
    return out, summary, options


def test_boards_without_a_reference_stay_with_the_reason(mixed):
    out, summary, _ = mixed
    assert summary.boards == 3
    assert summary.references == {"routed": 1, "not_completed": 1, "engine_failure": 1,
                                  "check_failed": 0}
    boards = _config(out)["splits"]["test"]["boards"]
    assert sorted(boards) == ["board_00000", "board_00001", "board_00002"]
    assert REFERENCE_FILE in boards["board_00000"]["files"]
    missed = boards["board_00001"]["reference_routing"]
    assert missed["status"] == "not_completed" and missed["seed"] is None
    assert missed["reason"].startswith("not completed in 1 rollouts; closest: seed 0, ")
    failed = boards["board_00002"]["reference_routing"]
    assert failed["status"] == "engine_failure" and failed["reason"].startswith("engine failure")
    for board_id in ("board_00001", "board_00002"):
        assert REFERENCE_FILE not in boards[board_id]["files"]
        assert not (out / "d2r-a" / "test" / board_id / REFERENCE_FILE).exists()
    assert main(["verify", str(out)]) == 0


def test_published_rows_carry_the_reference_where_there_is_one(mixed, tmp_path):
    import pcbdata

    rows = {r["board_id"]: r for r in pcbdata.load("d2r-a", split="test", root=str(mixed[0]),
                                                   cache_dir=str(tmp_path / "cache"))}
    assert rows["board_00000"]["reference"].startswith("(kicad_pcb")
    assert rows["board_00000"]["reference_routing_status"] == "routed"
    assert rows["board_00001"]["reference"] is None
    assert rows["board_00001"]["reference_routing_status"] == "not_completed"
    card = (mixed[0] / "README.md").read_text()
    assert "test 1 of 3 boards routed" in card


def test_eval_reference_scores_those_that_have_one(mixed, tmp_path, capsys):
    report = tmp_path / "report"
    assert main(["eval", str(mixed[0]), "--config", "d2r-a", "--reference", "--workers", "1",
                 "--out", str(report)]) == 0
    err = capsys.readouterr().err
    assert "2 of 3 boards have no reference board and are not scored" in err
    assert "(board_00001, board_00002)" in err
    summary = json.loads((report / "summary.json").read_text())
    assert summary["n_boards"] == 1 and summary["cp"] == 1.0 and summary["cp_strict"] == 1.0
    assert summary["n_boards_without_reference"] == 2
    assert summary["boards_without_reference"] == ["board_00001", "board_00002"]
    assert "2 of 3 boards have no reference board" in (report / "summary.md").read_text()


def test_engine_failures_are_tried_again(mixed, tmp_path):
    from pcbdata.build import build_level

    out, _, options = mixed
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    summary = build_level(copy, "d2r", "a", options=options)
    assert summary.references_kept == 2  # routed and not completed; the failure ran again
    assert summary.references["engine_failure"] == 1


def test_the_build_check_refuses_a_reference_that_is_not_clean(tmp_path, capsys):
    """A reference the worker wrongly calls routed fails the build's KiCad check: it is
    dropped with the reason, logged, and the build still ends with a manifest."""
    from pcbdata.build import SyntheticOptions, build_level
    from pcbdata.runners.reference import plan

    reference = dataclasses.replace(
        plan("scripted", 1), task="tests.builds.agents_for_reference:claims_the_bare_board")
    options = SyntheticOptions(splits=["test"], count=1, workers=1, reference=reference)
    summary = build_level(tmp_path / "set", "d2r", "a", options=options)
    assert summary.references["check_failed"] == 1 and summary.references["routed"] == 0
    board = _config(tmp_path / "set")["splits"]["test"]["boards"]["board_00000"]
    record = board["reference_routing"]
    assert record["status"] == "check_failed" and "unconnected items (expected 0)" in \
        record["reason"]
    assert REFERENCE_FILE not in board["files"]
    assert main(["verify", str(tmp_path / "set")]) == 0
    again = build_level(tmp_path / "set", "d2r", "a", options=options)  # logged: not routed again
    assert again.references_kept == 1 and again.references["check_failed"] == 1


def test_eval_reference_without_any_is_a_clear_error(tmp_path, capsys):
    out = tmp_path / "set"
    assert _build(out, "--no-check") == 0
    capsys.readouterr()
    assert main(["eval", str(out), "--config", "d2r-a", "--reference", "--out",
                 str(tmp_path / "report")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pcbdata: error: d2r-a/test: none of its 2 boards has a reference "
                          "board"), err
    assert "D2R sets built with --reference-agent" in err and "\n" not in err


@pytest.mark.parametrize("args, message", [
    (["--reference-agent", "random"], "invalid choice: 'random'"),
    (["--reference-agent", "--reference-rollouts", "0"], "must be an integer from 1 to 100"),
    (["--reference-rollouts", "3"], "--reference-rollouts needs --reference-agent"),
    (["--reference-splits", "test"], "--reference-splits needs --reference-agent"),
    (["--reference-agent", "--reference-splits", "tset"], "unknown split 'tset'"),
    (["--reference-agent", "--reference-splits", "train"],
     "--reference-splits: train is not among the splits being built (test)"),
])
def test_bad_options_are_one_line_errors_and_write_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "set"
    try:
        code = _build(out, *args)
    except SystemExit as exc:  # argparse's own checks (choices, types) exit
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pcbdata: error: ") and "\n" not in err and message in err, err
    assert not out.exists()

"""`pcbdata render` end to end in real KiCad: a tiny D2 set routed by `pcbdata rollout`, scored
by `pcbdata eval`, then drawn as boards, as RUNS, and as the best rollouts of the report next
to the references; bad inputs give one line (or a reason per board) while the rest is drawn."""
from __future__ import annotations

import io
import shutil

import numpy as np
import pytest
from PIL import Image

from pcbdata.cli import main
from pcbdata.core import drawing
from pcbdata.testing.sets import write_set

TITLE = 14  # pixels of the title bar above each panel (drawn in the ratsnest colour)


def picture(path) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(path.read_bytes())).convert("RGB"))


def ratsnest_pixels(image: np.ndarray) -> int:
    body = image[TITLE:]
    return int(np.all(body == np.asarray(drawing.RATSNEST, np.uint8), axis=-1).sum())


@pytest.fixture(scope="module")
def routed(tmp_path_factory):
    """A D2 set of two test boards, RUNS of the scripted agent, and the eval report."""
    root = tmp_path_factory.mktemp("render")
    board_set = write_set(root / "set", "d2", "test", 2)
    runs, report = root / "runs", root / "report"
    assert main(["rollout", str(board_set), "--config", "d2", "--split", "test", "--agent",
                 "scripted", "--workers", "1", "--out", str(runs)]) == 0
    assert main(["eval", str(board_set), "--config", "d2", "--split", "test", "--runs",
                 str(runs), "--out", str(report), "--k", "1", "--workers", "1"]) in (0, 1)
    return {"set": board_set, "runs": runs, "report": report}


def test_render_a_set_folder_and_runs_deterministically(routed, tmp_path, capsys):
    out = tmp_path / "bare"
    assert main(["render", str(routed["set"]), "--out", str(out), "--workers", "2"]) == 0
    printed = capsys.readouterr().out
    assert "[2/2]" in printed and "done: 2 pictures" in printed and "0 not drawn" in printed
    bare = out / "d2" / "test" / "board_00000" / "board.png"
    assert picture(bare).shape == (480 + TITLE, 640, 3)
    assert ratsnest_pixels(picture(bare)) > 200  # the task: every connection open
    runs_out = tmp_path / "runs"
    assert main(["render", str(routed["runs"]), "--out", str(runs_out)]) == 0
    routed_png = runs_out / "board_00000" / "0.png"
    assert main(["render", str(routed["runs"]), "--out", str(tmp_path / "small"), "--size",
                 "200x100"]) == 0
    assert picture(tmp_path / "small" / "board_00001" / "0.png").shape == (100 + TITLE, 200, 3)
    assert ratsnest_pixels(picture(routed_png)) < ratsnest_pixels(picture(bare))
    assert main(["render", str(routed["runs"]), "--out", str(tmp_path / "again")]) == 0
    assert (tmp_path / "again" / "board_00000" / "0.png").read_bytes() == \
        routed_png.read_bytes()  # same board, same bytes
    assert main(["render", str(routed["runs"] / "board_00000" / "0.kicad_pcb"), "--out",
                 str(tmp_path / "one")]) == 0
    # one file: named by its stem (the title differs), the same drawing
    assert np.array_equal(picture(tmp_path / "one" / "0.png")[TITLE:],
                          picture(routed_png)[TITLE:])


def test_render_best_rollouts_of_a_report_next_to_the_reference(routed, tmp_path, capsys):
    out = tmp_path / "best"
    assert main(["render", str(routed["runs"]), "--report", str(routed["report"]),
                 "--out", str(out)]) == 0
    assert picture(out / "board_00000.png").shape == (480 + TITLE, 640, 3)  # no set: one panel
    # give board_00000 a reference routing (D2 sets have none): its picture gets two panels
    folder = routed["set"] / "d2" / "test" / "board_00000"
    shutil.copyfile(routed["runs"] / "board_00000" / "0.kicad_pcb", folder / "reference.kicad_pcb")
    try:
        out = tmp_path / "with-set"
        assert main(["render", str(routed["runs"]), "--report", str(routed["report"]), "--set",
                     str(routed["set"]), "--config", "d2", "--out", str(out)]) == 0
    finally:
        (folder / "reference.kicad_pcb").unlink()
    assert picture(out / "board_00000.png").shape == (480 + TITLE, 2 * 640 + 6, 3)
    assert picture(out / "board_00001.png").shape == (480 + TITLE, 640, 3)
    assert "done: 2 pictures" in capsys.readouterr().out


def test_bad_boards_are_reasons_while_the_others_are_drawn(routed, tmp_path, capsys):
    boards = tmp_path / "boards"
    boards.mkdir()
    good = routed["set"] / "d2" / "test" / "board_00000" / "board.kicad_pcb"
    shutil.copyfile(good, boards / "good.kicad_pcb")
    (boards / "cut.kicad_pcb").write_bytes(good.read_bytes()[:2000])
    (boards / "junk.kicad_pcb").write_text("(not_a_board (version 1))\n")
    out = tmp_path / "out"
    assert main(["render", str(boards), "--out", str(out)]) == 3
    captured = capsys.readouterr()
    assert "cut: not drawn" in captured.out and "junk: not drawn" in captured.out
    assert "done: 1 pictures" in captured.out and "2 not drawn" in captured.out
    assert captured.err.strip() == "pcbdata: 2 boards could not be drawn (see above)"
    assert sorted(p.name for p in out.iterdir()) == ["good.png"]


@pytest.mark.parametrize(("args", "message"), [
    (["MISSING"], "no such file or folder"),
    (["RUNS", "--set", "SET", "--config", "d2"], "--set needs --report"),
    (["RUNS", "--report", "RUNS"], "no per_board.csv"),
    (["RUNS", "--report", "REPORT", "--set", "SET"], "--set needs --config"),
    (["RUNS", "--report", "REPORT", "--set", "SET", "--config", "d2", "--split", "train"],
     "no d2/train folder"),
    (["RUNS", "--workers", "0"], "argument --workers"),
    (["RUNS", "--timeout", "nan"], "argument --timeout"),
    (["RUNS", "--size", "10x10"], "argument --size: must be WxH"),
    (["REPORT/per_board.csv"], "not a .kicad_pcb file or a folder of boards"),
])
def test_bad_arguments_are_one_line(routed, tmp_path, capsys, args, message):
    names = {"MISSING": str(tmp_path / "missing.kicad_pcb"), "RUNS": str(routed["runs"]),
             "REPORT": str(routed["report"]), "SET": str(routed["set"]),
             "REPORT/per_board.csv": str(routed["report"] / "per_board.csv")}
    out = tmp_path / "out"
    try:
        code = main(["render", *[names.get(a, a) for a in args], "--out", str(out)])
    except SystemExit as exc:  # argparse
        code = exc.code
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("pcbdata: error: ")
    assert message in lines[0]
    assert not out.exists()


def test_out_that_is_a_file_is_one_line(routed, tmp_path, capsys):
    (tmp_path / "taken").write_text("x")
    code = main(["render", str(routed["runs"]), "--out", str(tmp_path / "taken")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("pcbdata: error: --out") and "not a folder" in err


def test_drc_markers_on_a_board_with_crossing_tracks(routed, tmp_path):
    import gymnasium as gym

    import pcbdata.env  # noqa: F401
    from tests.env.test_render import straight_lines_until_violation

    folder = tmp_path / "boards" / "board_00000"
    env = gym.make("pcbdata/Route-d2-v2", root=str(routed["set"]))
    try:
        _, info = env.reset(options={"index": 0})
        straight_lines_until_violation(env, info)  # net 3 crosses net 1
        env.unwrapped.save(folder / "board.kicad_pcb")
    finally:
        env.close()
    shutil.copyfile(routed["set"] / "d2" / "test" / "board_00000" / "board.kicad_pro",
                    folder / "board.kicad_pro")
    marker = np.asarray(drawing.MARKER, np.uint8)
    assert main(["render", str(folder / "board.kicad_pcb"), "--out", str(tmp_path / "plain")]) == 0
    plain = picture(tmp_path / "plain" / "board.png")
    assert not np.all(plain == marker, axis=-1).any()
    assert main(["render", str(folder / "board.kicad_pcb"), "--drc", "--out",
                 str(tmp_path / "drc")]) == 0
    marked = picture(tmp_path / "drc" / "board.png")
    assert np.all(marked == marker, axis=-1).sum() > 20

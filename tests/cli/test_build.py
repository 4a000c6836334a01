"""`pcbdata build d1|d2` and `pcbdata verify` end to end, with real KiCad checks."""
import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import pytest

from pcbdata.build.synthetic import ConfigInfo, SplitJob, build_synthetic
from pcbdata.cli import main
from pcbdata.core.errors import ValidationError
from pcbdata.generators.d2 import D2Generator, D2Params

PCBDATA = [sys.executable, "-m", "pcbdata"]


def run_cli(*args, cwd=None):
    return subprocess.run([*PCBDATA, *map(str, args)], capture_output=True, text=True, cwd=cwd)


def test_build_d2_writes_boards_manifest_and_verifies(tmp_path):
    out = tmp_path / "odd name (v1) 'x'"
    result = run_cli("build", "d2", "--splits", "validation,test", "--count", "12", "--out", out)
    assert result.returncode == 0, result.stderr
    assert "done: 24 boards" in result.stdout and "24 checked in KiCad" in result.stdout
    manifest = json.loads((out / "manifest.json").read_text())
    config = manifest["configs"]["d2"]
    assert manifest["kicad_version"] == "9.0.8" and manifest["package_version"]
    assert config["set_version"] and config["parameters"]["min_pad_spacing_mm"] == 4.8
    assert config["level"] == "default" and "SeedSequence" in config["seed_scheme"]
    board = config["splits"]["test"]["boards"]["board_00000"]
    assert sorted(board["files"]) == ["board.kicad_pcb", "board.kicad_pro"]
    assert {"n_nets", "n_pads", "n_layers", "width_mm", "height_mm"} <= set(board)
    assert config["splits"]["test"]["kicad_checked"] == 12
    assert sorted(p.name for p in (out / "d2" / "test").iterdir())[0] == "board_00000"
    verify = run_cli("verify", out)
    assert verify.returncode == 0 and "24 boards in d2: OK" in verify.stdout, verify.stdout
    (out / "d2" / "test" / "board_00003" / "board.kicad_pro").write_text("{}")
    verify = run_cli("verify", out)
    assert verify.returncode == 1
    assert "d2/test/board_00003/board.kicad_pro: altered" in verify.stdout


def test_two_builds_give_byte_identical_sets(tmp_path):
    for name in ("a", "b"):
        assert main(["build", "d1", "--grid", "10,500", "--splits", "test", "--count", "6",
                     "--placement", "random-walk", "--out", str(tmp_path / name)]) == 0
    files = lambda root: {str(p.relative_to(root)): p.read_bytes()  # noqa: E731
                          for p in sorted(root.rglob("*"))
                          if p.is_file() and ".pcbdata" not in p.parts}
    first, second = files(tmp_path / "a"), files(tmp_path / "b")
    assert first == second
    assert "d1-g10-random-walk/test/board_00000/reference.kicad_pcb" in first
    assert "d1-g500-random-walk/test.npz" in first


def test_building_more_splits_keeps_the_earlier_ones(tmp_path):
    for split in ("test", "validation"):
        assert main(["build", "d2", "--level", "hard", "--splits", split, "--count", "4",
                     "--out", str(tmp_path)]) == 0
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert sorted(manifest["configs"]["d2-hard"]["splits"]) == ["test", "validation"]
    assert main(["verify", str(tmp_path)]) == 0


@pytest.mark.parametrize("args, message", [
    (["d2", "--set", "net_counts=[0]"], "net_counts must list net counts >= 1"),
    (["d2", "--set", "net_counts=[60]", "--set", "pads_per_net={5=1.0}"], "pads per board"),
    (["d1", "--grid", "1"], "grid size must be an integer >= 2"),
    (["d1", "--grid", "abc"], "is not an integer grid size"),
    (["d2", "--level", "hardd"], "did you mean 'hard'"),
    (["d2", "--set", "spacing=3"], "unknown D2 parameter 'spacing'"),
    (["d2", "--set", "min_pad_spacing_mm=wide"], "is not a number"),
    (["d2", "--set", "pad_size_mm=[1,2]"], "must be a number"),
    (["d2", "--splits", "tests"], "unknown split 'tests'"),
])
def test_bad_input_is_one_line_exit_2_and_leaves_nothing(tmp_path, args, message):
    out = tmp_path / "set"
    result = run_cli("build", *args, "--out", out)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pcbdata: error: "), result.stderr
    assert message in lines[0], result.stderr
    assert not out.exists()


def test_out_folder_with_foreign_files_is_refused(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    result = run_cli("build", "d2", "--splits", "test", "--count", "2", "--out", tmp_path)
    assert result.returncode == 2 and "not a pcbdata board set" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_a_killed_build_resumes_to_the_same_bytes(tmp_path):
    args = ["build", "d2", "--splits", "train", "--count", "1000", "--check-train", "100"]
    clean = tmp_path / "clean"
    assert run_cli(*args, "--out", clean).returncode == 0
    resumed = tmp_path / "resumed"
    process = subprocess.Popen([*PCBDATA, *args, "--out", str(resumed)], start_new_session=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    while time.time() < deadline and len(list((resumed / "d2" / "train").glob("board_*"))) < 100:
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert not (resumed / "manifest.json").exists()
    result = run_cli(*args, "--out", resumed)
    assert result.returncode == 0, result.stderr
    assert "unchanged" in result.stdout
    for path in sorted(clean.rglob("*")):
        if path.is_file() and ".pcbdata" not in path.parts:
            assert (resumed / path.relative_to(clean)).read_bytes() == path.read_bytes(), path
    assert not list(resumed.rglob("*.tmp"))


class _OverlappingPadsGenerator(D2Generator):
    """A generator with a bug: the second pad sits on the first, so KiCad reports a short."""

    def generate(self, seed, split, index):
        instance = super().generate(seed, split, index)
        if index == 1:
            pads = instance.board.pads
            pads[1] = replace(pads[1], x=pads[0].x + 500_000, y=pads[0].y)
        return instance


def test_a_board_failing_its_kicad_check_stops_the_build_naming_board_violation_parameters(
        tmp_path):
    generator = _OverlappingPadsGenerator(D2Params())
    configs = {"d2-broken": ConfigInfo(family="d2", set_version="0", seed=0,
                                       parameters=generator.params.as_dict())}
    jobs = [SplitJob("d2-broken", "test", 3, generator, [0, 1, 2])]
    with pytest.raises(ValidationError) as error:
        build_synthetic(tmp_path, jobs, configs, workers=2)
    message = str(error.value)
    assert "d2-broken/test/board_00001/board.kicad_pcb" in message
    assert "board_00000" not in message and "min_pad_spacing_mm" in message
    assert "shorting_items" in message or "clearance" in message
    assert not (tmp_path / "manifest.json").exists()

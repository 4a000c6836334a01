"""Bad input to every verb is one line `pcbdata: error: ...` naming the input and the reason,
exit code 2, and nothing written; the limits themselves are checked in real KiCad."""
from __future__ import annotations

import errno
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.generators.d1 import D1Generator, D1Params
from pcbdata.generators.d2 import D2Generator, D2Params

PCBDATA = [sys.executable, "-m", "pcbdata"]
REPO = Path(__file__).resolve().parents[2]


def run_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([*PCBDATA, *map(str, args)], capture_output=True, text=True, cwd=REPO)


def run_main(args, capsys) -> tuple[int, str]:
    """Exit code and stderr of `pcbdata ARGS` run in this process (argparse exits)."""
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


def assert_one_line(code: int, err: str, message: str) -> str:
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("pcbdata: error: "), err
    assert message in lines[0], err
    return lines[0]


D2_BAD = [
    # not finite: TOML has nan and inf, also inside lists and tables
    (["pad_size_mm=nan"], "must be finite"),
    (["pad_size_mm=inf"], "must be finite"),
    (["clearance_mm=-inf"], "must be finite"),
    (["pad_size_mm=1e400"], "must be finite"),
    (["pad_size_mm=1" + "0" * 400], "must be finite"),
    (["width_mm=[nan,100]"], "must be finite"),
    (["height_mm=[80,inf]"], "must be finite"),
    (["pads_per_net={2=nan}"], "must be finite"),
    (["pads_per_net={2=1.0,3=inf}"], "must be finite"),
    # beyond what KiCad's int32 nanometres hold, or physically absurd
    (["width_mm=[1e9,1e9]"], "KiCad holds coordinates"),
    (["height_mm=[1500,2500]"], "<= 1000"),
    (["via_diameter_mm=2000"], "via_diameter_mm must be from 0.01 to 1000 mm"),
    (["pad_size_mm=0.001"], "pad_size_mm must be from 0.01"),
    (["clearance_mm=0"], "clearance_mm must be from 0.01"),
    (["track_width_mm=-1"], "track_width_mm must be from 0.01"),
    (["edge_clearance_mm=-0.1"], "edge_clearance_mm must be from 0"),
    (["lattice_mm=0"], "lattice_mm must be from 0.01"),
    (["drill_mm=2.4"], "drill_mm must be smaller than pad_size_mm"),
    (["via_drill_mm=1.2"], "via_drill_mm must be smaller than via_diameter_mm"),
    # accepted before, then every board failed its KiCad check (each measured)
    (["min_pad_spacing_mm=2.7", "roundrect_ratio=0"], "corner to corner"),   # shorting_items
    (["drill_mm=0.5"], "minimum hole size 0.6 mm"),                          # drill_out_of_range
    (["drill_mm=2.3"], "annular ring"),                                      # annular_width
    (["via_drill_mm=1.1"], "annular ring"),
    (["width_mm=[6,6]", "height_mm=[6,6]", "placement_fraction=0.7", "net_counts=[3]",
      "pads_per_net={5=1}", "pad_size_mm=0.8", "drill_mm=0.6", "min_pad_spacing_mm=0.86",
      "clearance_mm=0.05", "lattice_mm=0.01", "through_hole_fraction=1"],
     "hole clearance"),                                                      # hole_clearance
    (["lattice_mm=100"], "on the 100.0 mm lattice"),  # crashed: no lattice point to draw
    (["pad_size_mm=2", "pad_size_mm=3"], "--set pad_size_mm: given twice"),
]


@pytest.mark.parametrize("sets, message", D2_BAD, ids=[" ".join(s)[:40] for s, _ in D2_BAD])
def test_bad_d2_parameters(tmp_path, capsys, sets, message):
    out = tmp_path / "set"
    args = ["build", "d2", "--splits", "test", "--count", "2", "--no-check", "--out", out]
    for text in sets:
        args += ["--set", text]
    assert_one_line(*run_main(args, capsys), message)
    assert not out.exists()


def test_an_unknown_parameter_is_answered_with_the_closest_and_the_known_ones(tmp_path,
                                                                            capsys):
    out = tmp_path / "set"
    line = assert_one_line(*run_main(["build", "d2", "--out", out, "--set", "nets_max=-3"],
                                     capsys), "unknown D2 parameter 'nets_max'")
    assert "did you mean 'net_counts'?" in line
    assert line.endswith(f"(known: {', '.join(sorted(D2Params.keys()))})")
    line = assert_one_line(*run_main(["build", "d2", "--out", out, "--set", "zzz=1"], capsys),
                           "unknown D2 parameter 'zzz' (known: clearance_mm, drill_mm, ")
    assert "did you mean" not in line and not out.exists()


BUILD_BAD = [
    (["d1", "--grid", "5001"], "at most 5000"),
    (["d1", "--grid", "99999999999999999999"], "at most 5000"),
    (["d1", "--grid", "0"], "integer >= 2"),
    (["d1", "--grid", "10,10"], "grid 10 is listed twice"),
    (["d2", "--seed", "-5"], "argument --seed: seed must be an integer from 0 to 2**63 - 1"),
    (["d2", "--seed", str(2**63)], "from 0 to 2**63 - 1"),
    (["d1", "--seed", str(2**64 + 3)], "from 0 to 2**63 - 1"),
    (["d2", "--seed", "1.5"], "'1.5' is not an integer"),
    (["d2", "--count", "0"], "argument --count: must be an integer from 1 to 100000"),
    (["d2", "--count", "100001"], "from 1 to 100000"),
    (["d2", "--count", "many"], "argument --count: 'many' is not an integer"),
    (["d2", "--workers", "0"], "argument --workers: must be an integer from 1 to 1024"),
    (["d1", "--workers", "-2"], "argument --workers"),
    (["d2", "--check-train", "-1"], "argument --check-train: must be an integer >= 0"),
    (["d1", "--placement", "x"], "invalid choice"),  # an argparse error, one line too
]


@pytest.mark.parametrize("args, message", BUILD_BAD, ids=[" ".join(a) for a, _ in BUILD_BAD])
def test_bad_build_options(tmp_path, capsys, args, message):
    out = tmp_path / "set"
    count = [] if "--count" in args else ["--count", "2"]
    code, err = run_main(["build", *args, *count, "--splits", "test", "--no-check", "--out", out],
                         capsys)
    assert_one_line(code, err, message)
    assert not out.exists()


def test_d3_build_options(tmp_path, capsys):
    for option, value in (("--workers", "0"), ("--tasks-per-worker", "0")):
        code, err = run_main(["build", "d3", "--source", tmp_path, "--out", tmp_path / "o",
                              option, value], capsys)
        assert_one_line(code, err, f"argument {option}: must be an integer")
    # a folder that is not a checkout is refused before --out is created
    code, err = run_main(["build", "d3", "--source", tmp_path, "--out", tmp_path / "o"], capsys)
    assert_one_line(code, err, "not a PCBench checkout")
    assert not (tmp_path / "o").exists()


def test_generators_refuse_seeds_outside_the_pipeline():
    for generator in (D2Generator(D2Params()), D1Generator(D1Params(grid=10))):
        for seed in (-5, 2**63, True, 1.0):
            with pytest.raises(UserError, match="from 0 to 2"):
                generator.generate(seed, "test", 0)


def test_the_largest_seed_is_built_published_and_verified(tmp_path):
    """2**63 - 1 goes through the whole pipeline: boards, KiCad check, parquet, verify."""
    out = tmp_path / "set"
    seed = 2**63 - 1
    build = run_cli("build", "d2", "--splits", "test", "--count", "2", "--seed", seed,
                    "--workers", "2", "--out", out)
    assert build.returncode == 0, build.stderr
    assert run_cli("verify", out).returncode == 0
    rows = pq.read_table(out / "d2" / "test-00000-of-00001.parquet").to_pylist()
    assert [r["seed"] for r in rows] == [seed, seed]


def test_boards_at_the_limits_pass_their_kicad_check(tmp_path):
    """The limits are what KiCad holds: 1 m boards, 0.01 mm features, D1 grid 5000."""
    tiny = ["pad_size_mm=0.02", "drill_mm=0.01", "min_pad_spacing_mm=0.06", "clearance_mm=0.01",
            "track_width_mm=0.01", "edge_clearance_mm=0", "via_diameter_mm=0.22",
            "via_drill_mm=0.01", "lattice_mm=0.01", "through_hole_fraction=0"]
    builds = [["d2", "--set", "width_mm=[1000,1000]", "--set", "height_mm=[999,1000]"],
              ["d2", *[x for text in tiny for x in ("--set", text)]],
              ["d1", "--grid", "5000", "--placement", "random-walk"]]
    for k, args in enumerate(builds):
        out = tmp_path / f"set{k}"
        build = run_cli("build", *args, "--splits", "test", "--count", "2", "--workers", "2",
                        "--out", out)
        assert build.returncode == 0, build.stderr[-2000:]


# ---- --out: not a folder, read-only, full ------------------------------------------------

def test_out_that_is_a_file_or_under_a_file(tmp_path, capsys):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    line = assert_one_line(*run_main(["build", "d2", "--splits", "test", "--count", "1",
                                      "--no-check", "--out", a_file / "set"], capsys),
                           "cannot write there (Not a directory)")
    assert str(a_file / "set") in line
    assert_one_line(*run_main(["build", "d1", "--grid", "10", "--splits", "test", "--count",
                               "1", "--out", a_file], capsys), "exists and is not a folder")
    assert a_file.read_text() == "x"


def _in_private_mount(tmp_path: Path, options: str, script: str) -> subprocess.CompletedProcess:
    """Runs `script` (sh) with a fresh tmpfs mounted on tmp_path/mnt (mount options
    `options`) in a private mount namespace, so the mount vanishes with the process.
    Needs the right to mount (root in this container): skipped otherwise."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    if shutil.which("unshare") is None:
        pytest.skip("no unshare(1): cannot make a read-only or full file system")
    probe = subprocess.run(["unshare", "--mount", "sh", "-c",
                            f"mount -t tmpfs -o size=64k tmpfs '{mnt}'"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {probe.stderr.decode().strip()}")
    body = f"mount -t tmpfs -o {options} tmpfs '{mnt}' || exit 99\n{script}"
    return subprocess.run(["unshare", "--mount", "sh", "-c", body], capture_output=True,
                          text=True, cwd=REPO)


def test_out_on_a_read_only_file_system(tmp_path):
    """As root, chmod does not stop writes: a read-only tmpfs mount does."""
    python = " ".join(PCBDATA)
    script = (f"{python} build d2 --splits test --count 2 --no-check --out '{tmp_path}/mnt/set'"
              f"; echo rc=$?; ls -A '{tmp_path}/mnt'")
    proc = _in_private_mount(tmp_path, "ro,size=1m", script)
    assert "rc=2" in proc.stdout, proc.stdout + proc.stderr
    line = assert_one_line(2, proc.stderr, "cannot write there (Read-only file system)")
    assert f"{tmp_path}/mnt/set" in line
    assert proc.stdout.split("rc=2")[1].strip() == ""  # the folder holds nothing


def test_out_on_a_full_file_system(tmp_path):
    """A 200 kB tmpfs fills up after a few boards: one line naming the set folder and the
    OS reason, and what is on disk is whole: complete board folders, no temporary files."""
    out = f"{tmp_path}/mnt/set"
    python = " ".join(PCBDATA)
    check = ("import json, os, sys; root = sys.argv[1]; "
             "print(json.dumps({os.path.relpath(os.path.join(d, f), root): "
             "open(os.path.join(d, f), 'rb').read()[-2:].decode() "
             "for d, _, fs in os.walk(root) for f in fs}))")
    script = (f"{python} build d2 --splits test --count 60 --no-check --workers 2 --out '{out}'"
              f"; echo rc=$?; {sys.executable} -c \"{check}\" '{out}'")
    proc = _in_private_mount(tmp_path, "size=200k", script)
    assert "rc=2" in proc.stdout, proc.stdout + proc.stderr
    err = [line for line in proc.stderr.splitlines() if line.startswith("pcbdata: error")]
    assert len(err) == 1 and out in err[0] and "No space left on device" in err[0], proc.stderr
    assert "Traceback" not in proc.stderr
    files = json.loads(proc.stdout.split("rc=2")[1])
    boards = {Path(rel).parent for rel in files if rel.startswith("d2/test/")}
    assert boards and not any(".tmp" in rel for rel in files)
    assert "manifest.json" not in files
    for board in boards:  # every board folder is whole: both files, each ending its text
        assert files[f"{board}/board.kicad_pcb"] == ")\n"
        assert files[f"{board}/board.kicad_pro"] == "}\n"


def test_os_errors_of_writing_map_to_one_line():
    from pcbdata.cli._checks import write_error_line

    full = OSError(errno.ENOSPC, "No space left on device")  # a failed write(): no file name
    assert write_error_line(full, "/data/set").startswith("/data/set: No space left on device;")
    named = OSError(errno.EROFS, "Read-only file system", "/ro/set/x")
    assert write_error_line(named, "/ro/set").startswith("/ro/set/x: Read-only file system;")
    assert write_error_line(OSError(errno.EIO, "I/O error")) is None  # not an input problem


# ---- other verbs -------------------------------------------------------------------------

OTHER_BAD = [
    (["verify", "x", "--max-lines", "-1"], "--max-lines must be an integer >= 0"),
    (["publish", "x", "--previews", "-2"], "argument --previews: must be an integer >= 0"),
    (["route", "x", "--config", "d2", "--out", "r", "--rollouts", "0"], "argument --rollouts"),
    (["route", "x", "--config", "d2", "--out", "r", "--workers", "0"], "argument --workers"),
    (["route", "x", "--config", "d2", "--out", "r", "--timeout", "nan"], "argument --timeout"),
    (["route", "x", "--config", "d2", "--out", "r", "--limit", "0"], "argument --limit"),
    (["push", "x", "--repo", "a/b", "--tag", "v 1.0"], "--tag 'v 1.0': not a valid git tag"),
    (["push", "x", "--repo", "a/b", "--tag", "v1..0"], "not a valid git tag"),
    (["push", "x", "--repo", "a/b", "--tag=-v1"], "not a valid git tag"),
    (["push", "x", "--repo", "a/b", "--tag", "v1.lock"], "not a valid git tag"),
    (["push", "x", "--repo", "a/b", "--tag", "v1~2"], "not a valid git tag"),
    (["push", "x", "--repo", "a/b", "--tag", ""], "not a valid git tag (empty)"),
    (["push", "x", "--repo", "a/b--c"], "not a valid Hub repository id"),
    (["push", "x", "--repo", "a/" + "n" * 97], "not a valid Hub repository id"),
    (["eval"], "the following arguments are required"),
]


@pytest.mark.parametrize("args, message", OTHER_BAD, ids=[" ".join(a)[:40] for a, _ in OTHER_BAD])
def test_bad_options_of_other_verbs(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    assert_one_line(*run_main(args, capsys), message)
    assert list(tmp_path.iterdir()) == []


def test_a_valid_tag_is_accepted(tmp_path, capsys):
    """The tag check is not over-eager: a well-formed tag gets to the set checks."""
    code, err = run_main(["push", tmp_path / "nothing", "--repo", "a/b", "--tag",
                          "d2-v1.0.0/rc_1", "--dry-run"], capsys)
    assert_one_line(code, err, "no manifest")

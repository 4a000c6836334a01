"""The CLI without KiCad: `pcbnew` made unimportable (a shim module on PYTHONPATH that raises
ImportError) and no `kicad-cli` on PATH, in subprocesses. Help and generation need no KiCad;
a KiCad failure is one line naming the board and the reason, exit 3."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.conftest import REPO_ROOT

HELP_SCRIPT = """
import contextlib, io, json, sys
from pcbdata.cli import main, verb_modules

results = {}
commands = [[m.VERB] for m in verb_modules()]
commands += [["build", m.FAMILY] for m in verb_modules(prefix="build_")]
for args in [[]] + commands:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            code = main([*args, "--help"])
        except SystemExit as exc:
            code = exc.code
    results[" ".join(args) or "pcbdata"] = [code, out.getvalue()]
results["pcbnew imported"] = "pcbnew" in sys.modules
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def no_kicad_env(tmp_path_factory):
    shim = tmp_path_factory.mktemp("no-pcbnew")
    (shim / "pcbnew.py").write_text('raise ImportError("pcbnew made unimportable by the test")\n')
    empty_path = tmp_path_factory.mktemp("empty-path")  # no kicad-cli either
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(shim), str(REPO_ROOT), env.get("PYTHONPATH", "")) if p)
    env["PATH"] = str(empty_path)
    probe = subprocess.run([sys.executable, "-c", "import pcbnew"], env=env, capture_output=True,
                           text=True)
    assert probe.returncode != 0 and "made unimportable" in probe.stderr
    return env


def _pcbdata(env, *args):
    return subprocess.run([sys.executable, "-m", "pcbdata", *map(str, args)], env=env,
                          capture_output=True, text=True, timeout=600)


def test_help_of_every_verb_and_build_family_works_without_kicad(no_kicad_env):
    result = subprocess.run([sys.executable, "-c", HELP_SCRIPT], env=no_kicad_env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    results = json.loads(result.stdout)
    assert results.pop("pcbnew imported") is False
    expected = {"pcbdata", "build", "build d1", "build d2", "build d2r", "build d3", "eval",
                "levels", "materialize", "publish", "push", "route", "verify"}
    assert expected <= set(results), sorted(results)
    for command, (code, text) in results.items():
        assert code == 0 and text.startswith("usage: "), (command, code, text[:200])


def test_build_d2_no_check_works_without_kicad(no_kicad_env, tmp_path):
    out = tmp_path / "set"
    result = _pcbdata(no_kicad_env, "build", "d2", "--splits", "test", "--count", "3",
                      "--no-check", "--workers", "1", "--out", out)
    assert result.returncode == 0, result.stderr
    assert "done: 3 boards" in result.stdout
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["kicad_version"] == "unknown"  # nothing was checked in KiCad
    assert manifest["configs"]["d2"]["splits"]["test"]["kicad_checked"] == 0
    pictures = sorted(p.name for p in (out / "pictures" / "d2").iterdir())
    assert pictures == ["pads.svg"]  # published; no board previews without kicad-cli
    assert _pcbdata(no_kicad_env, "verify", out).returncode == 0


def test_a_kicad_failure_is_one_line_naming_the_board_exit_3(no_kicad_env, tmp_path):
    out = tmp_path / "set"
    result = _pcbdata(no_kicad_env, "build", "d2", "--splits", "test", "--count", "2",
                      "--workers", "1", "--out", out)
    assert result.returncode == 3, result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("pcbdata: KiCad failed: d2/test/board_0000"), result.stderr
    assert "board.kicad_pcb: " in last and "made unimportable" in last
    assert "(and 1 more boards)" in last
    assert "Traceback" not in result.stderr
    assert not (out / "manifest.json").exists()

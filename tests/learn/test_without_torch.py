"""Without the train extra: `torch` made unimportable (a shim module on PYTHONPATH), every
`--help` works and imports no torch; `pcbdata train` and `--agent policy` fail with one line."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.cli.test_without_kicad import HELP_SCRIPT
from tests.conftest import REPO_ROOT


@pytest.fixture(scope="module")
def no_torch_env(tmp_path_factory):
    shim = tmp_path_factory.mktemp("no-torch")
    (shim / "torch.py").write_text('raise ImportError("torch made unimportable by the test")\n')
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(shim), str(REPO_ROOT), env.get("PYTHONPATH", "")) if p)
    return env


def test_help_works_and_imports_no_torch(no_torch_env):
    script = HELP_SCRIPT.replace('"pcbnew" in sys.modules', '"torch" in sys.modules')
    result = subprocess.run([sys.executable, "-c", script], env=no_torch_env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    results = json.loads(result.stdout)
    assert results.pop("pcbnew imported") is False  # here: torch
    assert "train" in results
    for command, (code, text) in results.items():
        assert code == 0 and text.startswith("usage: "), (command, code, text[:200])


def test_train_without_torch_is_one_line(no_torch_env, tmp_path):
    result = subprocess.run([sys.executable, "-m", "pcbdata", "train", "--out",
                             str(tmp_path / "run")], env=no_torch_env, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 2
    assert result.stderr.startswith("pcbdata: error: pcbdata train needs the train extra")
    assert len(result.stderr.strip().splitlines()) == 1 and not (tmp_path / "run").exists()

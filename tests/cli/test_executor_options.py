"""`--executor` / `--ray-address` on `build d1|d2|d3` and `eval` (one shared helper)."""
from __future__ import annotations

import json
import sys

import pytest

from pcbdata.cli import main, make_parser

VERBS = (["build", "d1"], ["build", "d2"], ["build", "d3"], ["eval"])


def test_every_verb_takes_the_executor_options(monkeypatch, capsys):
    monkeypatch.setenv("RAY_ADDRESS", "10.1.2.3:6379")
    parser = make_parser()  # the default address is read when the parser is made
    for verb in VERBS:
        with pytest.raises(SystemExit):
            parser.parse_args([*verb, "--help"])
        text = capsys.readouterr().out
        assert "--executor {local,ray}" in text and "--ray-address ADDRESS" in text, verb
    args = parser.parse_args(["build", "d2", "--out", "x", "--executor", "ray"])
    assert (args.executor, args.ray_address) == ("ray", "10.1.2.3:6379")
    args = parser.parse_args(["build", "d2", "--out", "x", "--ray-address", "h:1"])
    assert (args.executor, args.ray_address) == ("local", "h:1")
    with pytest.raises(SystemExit):
        parser.parse_args(["build", "d2", "--out", "x", "--executor", "dask"])


def test_executor_ray_without_ray_is_one_line_and_writes_nothing(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if not installed
    code = main(["build", "d2", "--out", str(tmp_path / "set"), "--splits", "test",
                 "--count", "2", "--no-check", "--executor", "ray"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("pcbdata: error: the Ray executor needs Ray")
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "set").exists()


def test_build_d2_on_ray_from_the_command_line(ray_cluster, tmp_path, capsys):
    out = tmp_path / "set"
    code = main(["build", "d2", "--out", str(out), "--splits", "test", "--count", "2",
                 "--no-check", "--executor", "ray"])
    assert code == 0, capsys.readouterr().err
    assert "(executor ray)" in capsys.readouterr().err
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["configs"]["d2"]["splits"]["test"]["boards"]) == 2

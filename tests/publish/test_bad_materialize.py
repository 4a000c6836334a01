"""`pcbdata materialize` refuses what `load` refuses, and checks every row before it writes:
a refused run leaves nothing in --out."""
from __future__ import annotations

import hashlib
import shutil

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import pcbdata
from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.publish import materialize

SHARD = "d2/test-00000-of-00001.parquet"


def _rewrite(path, change) -> None:
    """Rewrites a parquet shard with `change(rows)` applied, keeping its schema."""
    table = pq.read_table(path)
    rows = table.to_pylist()
    change(rows)
    pq.write_table(pa.Table.from_pylist(rows, schema=table.schema), path)


def _edit_board(rows) -> None:
    """An edit that keeps the row self-consistent: the text and its sha256 column agree."""
    rows[0]["board"] = rows[0]["board"].replace("(net 1", "(net 1 ", 1)
    rows[0]["sha256"] = hashlib.sha256(rows[0]["board"].encode("utf-8")).hexdigest()


def refused(args, capsys) -> str:
    assert main([str(a) for a in args]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pcbdata: error: ")
    return lines[0]


def test_an_altered_row_with_its_hash_recomputed_is_refused_like_load(published_copy, tmp_path,
                                                                      capsys):
    _rewrite(published_copy / SHARD, _edit_board)
    with pytest.raises(UserError, match="sha256 differs from publish.json") as from_load:
        pcbdata.load("d2", split="test", root=published_copy)
    out = tmp_path / "out"
    line = refused(["materialize", published_copy, "--out", out], capsys)
    assert line == f"pcbdata: error: {from_load.value}"
    assert refused(["materialize", published_copy / SHARD, "--out", out], capsys) == line
    assert not out.exists()
    # the shard taken out of its set (no publish.json to compare with) is read as it is
    alone = tmp_path / "alone.parquet"
    shutil.copy(published_copy / SHARD, alone)
    assert materialize([alone], out)["written"] == 3


def _loose_shard(published, tmp_path, change):
    """A copy of the d2 test shard outside any set folder, with `change(rows)` applied."""
    shard = tmp_path / "loose.parquet"
    shutil.copy(published / SHARD, shard)
    _rewrite(shard, change)
    return shard


def test_every_row_is_checked_before_anything_is_written(published, tmp_path, capsys):
    shard = _loose_shard(published, tmp_path,  # the last row damaged
                         lambda rows: rows[2].update(board=rows[2]["board"] + " "))
    out = tmp_path / "out"
    assert "board.kicad_pcb does not match its sha256" in refused(
        ["materialize", shard, "--out", out], capsys)
    assert not out.exists()  # rows 0 and 1 were fine, and are not written either


def test_a_row_naming_a_path_is_refused(published, tmp_path, capsys):
    shard = _loose_shard(published, tmp_path,
                         lambda rows: rows[1].update(board_id="../../escaped"))
    assert "board_id '../../escaped' is not a plain folder name" in refused(
        ["materialize", shard, "--out", tmp_path / "out"], capsys)
    assert not (tmp_path / "out").exists() and not (tmp_path / "escaped").exists()


def test_selections_that_would_drop_or_overwrite_rows_are_refused(published, tmp_path, capsys):
    out = tmp_path / "out"
    # d1-g10 and d2 both hold board_00000: --flat would write one over the other
    assert "two different rows would be written there" in refused(
        ["materialize", published, "--flat", "--out", out], capsys)
    assert "board_99999" in refused(
        ["materialize", published, "--board", "board_00001", "--board", "board_99999",
         "--out", out], capsys)
    assert "unknown split 'tset'" in refused(
        ["materialize", published, "--split", "tset", "--out", out], capsys)
    assert not out.exists()
    a_file = tmp_path / "file"
    a_file.write_text("x")
    assert "exists and is not a folder" in refused(
        ["materialize", published, "--out", a_file], capsys)

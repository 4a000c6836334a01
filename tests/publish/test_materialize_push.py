"""Rows back to files (byte-identical to the built tree, and KiCad opens them); `push`."""
from __future__ import annotations

import filecmp

import pytest

import pcbdata
from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.model.manifest import read_manifest
from pcbdata.publish import iter_boards, materialize, materialize_row, row_files


def _board_folders(root):
    manifest = read_manifest(root)
    for config, entry in manifest["configs"].items():
        for split, split_entry in entry["splits"].items():
            for board_id, board in split_entry["boards"].items():
                yield config, split, board_id, board


def test_materialize_round_trip_is_byte_identical(published, tmp_path):
    out = tmp_path / "tree"
    result = materialize([published], out)
    assert sorted(result["recipes"]) == ["d3-b/full/0003_project_2", "d3-b/test/0003_project_2"]
    written = 0
    for config, split, board_id, board in _board_folders(published):
        folder = out / config / split / board_id
        if board_id == "0003_project_2":
            assert not folder.exists()
            continue
        assert sorted(p.name for p in folder.iterdir()) == sorted(board["files"])
        for name in board["files"]:
            src = published / config / split / board_id / name
            assert (folder / name).read_bytes() == src.read_bytes(), (config, split, board_id, name)
        written += 1
    assert written == result["written"] == 22


def test_materialize_cli_from_shards_with_filters(published, tmp_path, capsys):
    shard = published / "d1-g10" / "test-00000-of-00001.parquet"
    assert main(["materialize", str(shard), "--out", str(tmp_path / "a"),
                 "--board", "board_00001"]) == 0
    assert "wrote 1 boards" in capsys.readouterr().out
    folder = tmp_path / "a" / "d1-g10" / "test" / "board_00001"
    assert filecmp.cmp(folder / "board.kicad_dru",
                       published / "d1-g10/test/board_00001/board.kicad_dru", shallow=False)
    assert main(["materialize", str(published), "--config", "d3-b", "--split", "full", "--flat",
                 "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "wrote 3 boards" in out and "skipped 1 recipe rows" in out
    assert (tmp_path / "b" / "0001_project_0" / "reference.kicad_pcb").is_file()
    assert main(["materialize", str(published), "--config", "d2-default",
                 "--out", str(tmp_path / "c")]) == 2
    assert "unknown config 'd2-default'" in capsys.readouterr().err
    assert main(["materialize", str(tmp_path / "nothing"), "--out", str(tmp_path / "c")]) == 2


def test_iter_boards_and_row_helpers(published, tmp_path):
    ds = pcbdata.load("d3-b", split="full", root=published)
    seen = []
    for board in iter_boards(ds):
        assert board.board_path.is_file() and board.project_path.is_file()
        assert board.reference_path is not None
        original = published / "d3-b/full" / board.board_id / "board.kicad_pcb"
        assert board.board_path.read_bytes() == original.read_bytes()
        seen.append(board.board_id)
    assert seen == ["0001_project_0", "0002_project_1", "0004_project_3"]
    kept = list(iter_boards("d2", split="validation", root=published, workdir=tmp_path / "keep"))
    assert [b.folder for b in kept] == [tmp_path / "keep" / "board_00000",
                                        tmp_path / "keep" / "board_00001"]
    assert all(b.board_path.is_file() for b in kept)
    recipe = next(r for r in ds if not r["redistributable"])
    with pytest.raises(UserError, match="recipe row"):
        row_files(recipe)
    with pytest.raises(UserError, match="recipe row"):
        list(iter_boards([recipe], skip_recipes=False))
    damaged = dict(ds[0], board=ds[0]["board"] + " ")
    with pytest.raises(UserError, match="does not match its sha256"):
        materialize_row(damaged, tmp_path / "x")


def test_materialized_boards_load_and_check_in_kicad(published, tmp_path, kicad_pool):
    out = tmp_path / "tree"
    paths = []
    for config in ("d2", "d1-g10"):
        ds = pcbdata.load(config, split="test", root=published)
        folder = materialize_row(ds[0], out)
        paths.append(str(folder / "board.kicad_pcb"))
    for path, config in zip(paths, ("d2", "d1-g10")):
        report = kicad_pool.call("pcbdata.kicad.basics:drc", path)
        kinds = {v["section"] for v in report["violations"]}
        # a bare board: only the connections that routing will make are reported
        assert kinds == {"unconnected"}, (config, [v["type"] for v in report["violations"]])


def test_push_dry_run_lists_the_dataset_not_the_tree(published, capsys):
    assert main(["push", str(published), "--repo", "someone/pcbworld-bench", "--dry-run"]) == 0
    out = capsys.readouterr().out
    lines = [line.split()[-1] for line in out.splitlines() if line.startswith(" ")]
    assert "README.md" in lines and "manifest.json" in lines and "ATTRIBUTION.md" in lines
    assert "d2/test-00000-of-00001.parquet" in lines and "d1-g10/test.npz" in lines
    assert "pictures/d2/pads.svg" in lines
    assert not any("/board_0" in line and not line.startswith("pictures/") for line in lines)
    assert "tag d1-v1.0.0, d2-v2.0.0, d3-v1.0.0" in out


def test_push_offline_fails_with_one_clear_line(published, capsys):
    assert main(["push", str(published), "--repo", "someone/pcbworld-bench", "--tag", "v1.0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("pcbdata: error: cannot push")
    assert main(["push", str(published), "--repo", "not a repo"]) == 2
    assert "expected OWNER/NAME" in capsys.readouterr().err


def test_push_refuses_an_unpublished_set(published_copy, capsys):
    (published_copy / "README.md").unlink()
    assert main(["push", str(published_copy), "--repo", "a/b", "--dry-run"]) == 2
    assert "not ready to push" in capsys.readouterr().err

"""Damaged and half-written sets give clear errors; publishing is atomic and idempotent."""
from __future__ import annotations

import json
import os
import shutil

import datasets
import pytest

import pcbdata
from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_file
from pcbdata.model.manifest import read_manifest, write_manifest
from pcbdata.publish import publish_set, publisher, verify_published
from tests.publish.setbuilder import make_set


def _published_files(root):
    skip = {".pcbdata-publish.lock"}
    return {str(p.relative_to(root)): sha256_file(p) for p in sorted(root.rglob("*"))
            if p.is_file() and p.name not in skip and (p.suffix in (".parquet", ".svg", ".md")
                                                      or p.name == "publish.json")}


def test_corrupted_shard_gives_a_clear_error(published_copy):
    shard = published_copy / "d2" / "test-00000-of-00001.parquet"
    data = bytearray(shard.read_bytes())
    data[len(data) // 2: len(data) // 2 + 64] = b"\x00" * 64  # damage a data page
    shard.write_bytes(bytes(data))
    with pytest.raises(UserError, match=r"test-00000-of-00001.parquet: corrupt parquet shard"):
        pcbdata.load("d2", split="test", root=published_copy)
    problems = verify_published(published_copy, read_manifest(published_copy))
    assert problems == ["d2/test-00000-of-00001.parquet: shard altered or corrupt (sha256 differs "
                        "from publish.json)", "d2/test: 3 boards of the manifest not found in the "
                        "readable shards (see the damaged shard above)"]
    # the other splits are untouched
    assert len(pcbdata.load("d2", split="validation", root=published_copy)) == 2


def test_truncated_shard_is_reported(published_copy):
    shard = published_copy / "d1-g10" / "train-00000-of-00001.parquet"
    shard.write_bytes(shard.read_bytes()[:100])
    with pytest.raises(UserError, match="corrupt parquet shard"):
        pcbdata.load("d1-g10", split="train", root=published_copy)
    (published_copy / "publish.json").unlink()  # without recorded hashes, reading finds it
    problems = verify_published(published_copy, read_manifest(published_copy))
    assert len(problems) == 2, problems
    assert problems[0].startswith("d1-g10/train-00000-of-00001.parquet: corrupt shard (")


def test_missing_card_gives_a_clear_error(published_copy):
    (published_copy / "README.md").unlink()
    with pytest.raises(UserError, match="no dataset card.*not published.*pcbdata publish"):
        pcbdata.load("d2", root=published_copy)
    problems = verify_published(published_copy, read_manifest(published_copy))
    assert len(problems) == 1 and "missing dataset card" in problems[0]
    # datasets itself finds no config either
    with pytest.raises(FileNotFoundError, match="No \\(supported\\) data files found"):
        datasets.load_dataset(str(published_copy), "d2", split="test")


def test_missing_shard_is_named(published_copy):
    (published_copy / "d3-b" / "full-00000-of-00001.parquet").unlink()
    with pytest.raises(UserError,
                       match="full-00000-of-00001.parquet: shard listed in the card is missing"):
        pcbdata.load("d3-b", split="full", root=published_copy)
    problems = verify_published(published_copy, read_manifest(published_copy))
    assert problems == ["d3-b/full-00000-of-00001.parquet: shard missing",
                        "d3-b/full: 4 boards of the manifest not found in the readable shards "
                        "(see the damaged shard above)"]


def test_verify_names_missing_extra_and_altered_boards(published):
    manifest = read_manifest(published)
    boards = manifest["configs"]["d2"]["splits"]["test"]["boards"]
    boards["board_99999"] = dict(boards["board_00000"])              # in manifest, not in rows
    del boards["board_00001"]                                         # in rows, not in manifest
    boards["board_00002"] = json.loads(json.dumps(boards["board_00002"]))
    boards["board_00002"]["files"]["board.kicad_pro"] = "0" * 64      # altered
    problems = verify_published(published, manifest)
    assert problems == [
        "d2/test/board_00002: board.kicad_pro altered (row sha256 differs from the manifest)",
        "d2/test/board_99999: missing from the parquet rows",
        "d2/test/board_00001: extra row, not in the manifest",
    ]
    manifest["configs"]["d2-hard"] = manifest["configs"]["d2"]
    problems = verify_published(published, manifest)
    assert "d2-hard: in the manifest but not published (not in the card)" in problems


def test_altered_row_text_is_detected(published_copy):
    import pyarrow.parquet as pq

    shard = published_copy / "d2" / "validation-00000-of-00001.parquet"
    table = pq.read_table(shard)
    boards = table.column("board").to_pylist()
    boards[0] = boards[0].replace("NET1", "NET9")
    import pyarrow as pa

    table = table.set_column(table.schema.get_field_index("board"), table.schema.field("board"),
                             pa.chunked_array([pa.array(boards, pa.large_string())]))
    pq.write_table(table, shard, compression="zstd")
    (published_copy / "publish.json").unlink()
    problems = verify_published(published_copy, read_manifest(published_copy))
    assert problems == ["d2/validation/board_00000: board.kicad_pcb altered (text does not "
                        "match its sha256)"]


def test_publish_config_typo_suggests(published_copy):
    with pytest.raises(UserError, match=r"unknown config 'd1-g01'; did you mean 'd1-g10'\?"):
        publish_set(published_copy, ["d1-g01"])


def test_publish_refuses_a_tree_altered_after_the_build(tmp_path):
    root = tmp_path / "set"
    make_set(root, d2={"test": 2}, d1={"test": 1}, d3=False)
    (root / "d2" / "test" / "board_00001" / "board.kicad_pcb").write_text("(kicad_pcb)")
    with pytest.raises(UserError,
                       match="board_00001/board.kicad_pcb: sha256 differs from the manifest"):
        publish_set(root, previews=0)
    assert not (root / "README.md").exists()


@pytest.mark.parametrize("fail_at", ["staging", "commit"])
def test_interrupted_publishing_never_looks_complete(tmp_path, monkeypatch, fail_at):
    root = tmp_path / "set"
    make_set(root, d2={"test": 3, "validation": 2}, d1={"test": 2}, d3=False)
    publish_set(root, previews=0)
    assert verify_published(root, read_manifest(root)) == []
    # the set is rebuilt with other boards, then publishing it is stopped half way
    make_set(root, d2={"test": 4, "validation": 2}, d1={"test": 3}, d3=False)
    if fail_at == "staging":
        real = publisher._write_split
        calls = []

        def write_split(*args):
            calls.append(args)
            if len(calls) == 3:
                raise KeyboardInterrupt
            return real(*args)

        monkeypatch.setattr(publisher, "_write_split", write_split)
    else:
        real = os.replace
        calls = []

        def replace(src, dst):
            if ".pcbdata-publish.tmp" not in str(dst):  # a move from staging into the set
                calls.append(dst)
            if len(calls) == 2:  # after the card was removed and one shard moved into place
                raise KeyboardInterrupt
            return real(src, dst)

        monkeypatch.setattr(publisher.os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        publish_set(root, previews=0)
    monkeypatch.undo()
    assert not (root / ".pcbdata-publish.tmp").exists()
    problems = verify_published(root, read_manifest(root))
    assert problems, "a half-published set must not verify"
    if fail_at == "commit":
        assert problems == [f"{root}: publishing was interrupted (the card is a stub); run "
                            f"`pcbdata publish {root}` again"]
        with pytest.raises(UserError, match="publishing was interrupted"):
            pcbdata.load("d2", root=root)
        with pytest.raises(FileNotFoundError, match="No \\(supported\\) data files found"):
            datasets.load_dataset(str(root), "d2", split="test")
        assert main(["verify", str(root)]) == 1
    else:  # nothing was committed: the old card and old shards, which verify flags as stale
        assert any("board_00003: missing from the parquet rows" in p for p in problems)
    publish_set(root, previews=0)  # running again completes it
    assert verify_published(root, read_manifest(root)) == []
    assert len(pcbdata.load("d2", split="test", root=root)) == 4


def test_publishing_is_idempotent_and_removes_stale_shards(tmp_path, monkeypatch):
    root = tmp_path / "set"
    make_set(root, d2={"test": 6, "validation": 2}, d1={"test": 2}, d3=False)
    monkeypatch.setattr(publisher, "SHARD_BYTES", 30_000)  # ~2 boards per shard
    publish_set(root, previews=1)
    first = _published_files(root)
    shards = sorted(p for p in first if p.startswith("d2/test-"))
    assert shards == [f"d2/test-0000{k}-of-00003.parquet" for k in range(3)]
    assert len(pcbdata.load("d2", split="test", root=root)) == 6
    mtimes = {p: os.stat(root / p).st_mtime_ns for p in first if p.endswith(".parquet")}
    publish_set(root, previews=1)  # up to date: nothing rewritten
    assert {p: os.stat(root / p).st_mtime_ns for p in mtimes} == mtimes
    publish_set(root, previews=1, force=True)  # rewritten: same bytes
    assert _published_files(root) == first
    monkeypatch.setattr(publisher, "SHARD_BYTES", 10**9)
    publish_set(root, ["d2"], previews=1)
    now = _published_files(root)
    assert sorted(p for p in now if p.startswith("d2/test-")) == ["d2/test-00000-of-00001.parquet"]
    assert not (root / shards[1]).exists()
    assert verify_published(root, read_manifest(root)) == []
    assert len(pcbdata.load("d2", split="test", root=root)) == 6


def test_a_config_dropped_from_the_manifest_is_unpublished(tmp_path):
    root = tmp_path / "set"
    manifest = make_set(root, d2={"test": 2}, d1={"test": 2}, d3=False)
    publish_set(root, previews=0)
    del manifest["configs"]["d1-g10"]
    write_manifest(root, manifest)
    assert main(["publish", str(root), "--previews", "0"]) == 0
    assert not list((root / "d1-g10").glob("*.parquet"))
    assert verify_published(root, read_manifest(root)) == []
    with pytest.raises(UserError, match="unknown config 'd1-g10'"):
        pcbdata.load("d1-g10", root=root)
    shutil.rmtree(root / "d1-g10")


def test_killed_publisher_never_leaves_a_set_that_looks_complete(tmp_path):
    """SIGKILL a real `pcbdata publish` at spread-out moments: each time the set is either not
    loadable (no card or the stub card) or complete and verifying; running again completes it."""
    import signal
    import subprocess
    import sys
    import time

    root = tmp_path / "set"
    make_set(root, d2={"train": 40, "test": 20}, d1={"train": 30, "test": 10}, d3=False)
    command = [sys.executable, "-m", "pcbdata", "publish", str(root), "--previews", "1", "--force"]
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    duration = time.perf_counter() - start
    outcomes = set()
    for k in range(1, 7):
        make_set(root, d2={"train": 40, "test": 20 + k}, d1={"train": 30, "test": 10}, d3=False)
        proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(duration * k / 7)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        card = root / "README.md"
        manifest = read_manifest(root)
        if card.is_file() and "pcbdata_publishing_interrupted" not in card.read_text():
            problems = verify_published(root, manifest)
            if problems:  # killed before the commit: the previous card, which verify rejects
                outcomes.add("previous")
                assert any("missing from the parquet rows" in p for p in problems), problems
            else:
                outcomes.add("complete")
                assert len(pcbdata.load("d2", split="test", root=root)) == 20 + k
        else:
            outcomes.add("stub" if card.is_file() else "none")
            with pytest.raises(UserError):
                pcbdata.load("d2", split="test", root=root)
            assert verify_published(root, manifest)
    publish_set(root, previews=0)
    assert verify_published(root, read_manifest(root)) == []
    assert len(pcbdata.load("d2", split="test", root=root)) == 26
    assert outcomes

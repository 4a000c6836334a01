"""`pcbdata verify` reports what the manifest does not list, at every level: config and split
folders (two concurrent builds once left a split unpublished and verify said OK), files in
config, split and board folders, top-level entries and pictures; but not what builds,
publishing and a Hub download legitimately leave (state folders, D3 tables, lock, .cache)."""
from __future__ import annotations

from pathlib import Path

from pcbdata.cli import main
from pcbdata.model.manifest import read_manifest, write_manifest
from pcbdata.publish import publish_set
from pcbdata.sets.verify import verify_set


def _drop_from_manifest(root: Path, config: str, split: str | None = None) -> None:
    """What the slower of two concurrent builds does: rewrite the manifest without the other
    build's entry, then publish it."""
    manifest = read_manifest(root)
    if split is None:
        del manifest["configs"][config]
    else:
        del manifest["configs"][config]["splits"][split]
    write_manifest(root, manifest)
    publish_set(root, previews=0)


def _touch(path: Path, text: str = "x") -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_a_split_folder_the_manifest_does_not_list_is_reported(published_copy, capsys):
    _drop_from_manifest(published_copy, "d2", "train")
    assert verify_set(published_copy) == [
        "d2/train: split folder not in the manifest (4 entries unlisted)"]
    assert main(["verify", str(published_copy)]) == 1
    assert "d2/train: split folder not in the manifest" in capsys.readouterr().out


def test_a_config_folder_the_manifest_does_not_list_is_reported(published_copy):
    _drop_from_manifest(published_copy, "d1-g10")
    # train, validation, test and their three .npz arrays (publishing removed its shards)
    assert verify_set(published_copy) == [
        "d1-g10: config folder not in the manifest (6 entries unlisted)"]


def test_unknown_top_level_entries_are_reported(published_copy):
    _touch(published_copy / "notes.txt")
    _touch(published_copy / "scratch" / "board.kicad_pcb")
    assert verify_set(published_copy) == [
        "notes.txt: extra file not in the manifest",
        "scratch: config folder not in the manifest (1 entries unlisted)",
    ]


def test_what_builds_publishing_and_downloads_leave_is_not_reported(published_copy):
    for rel in (".pcbdata/checks.jsonl", ".d3-state/0123abcd.json",
                ".d3-state/0123abcd/board.kicad_pcb",
                ".cache/huggingface/download/README.md.metadata", ".gitattributes",
                "characteristics.csv", "curation_report.csv", "curation_report.json",
                "attribution.csv", "attribution.json", "LICENSE-PCBench"):
        _touch(published_copy / rel)
    assert (published_copy / ".pcbdata-publish.lock").is_file()  # left by every publish
    assert (published_copy / "ATTRIBUTION.md").is_file() and (published_copy / "pictures").is_dir()
    assert verify_set(published_copy) == []


def test_extra_files_in_config_split_and_board_folders_are_reported(published_copy):
    _touch(published_copy / "d2" / "notes.txt")
    _touch(published_copy / "d2" / "train-00000-of-00002.parquet")  # a stale shard
    _touch(published_copy / "d2" / "test" / "README.txt")
    (published_copy / "d2" / "test" / ".board_00001.k2j3.tmp").mkdir()
    _touch(published_copy / "d2" / "test" / "board_00001" / "board.kicad_prl")
    assert verify_set(published_copy) == [
        "d2/test/board_00001/board.kicad_prl: extra file not in the manifest",
        "d2/test/.board_00001.k2j3.tmp: leftover of an interrupted run",
        "d2/test/README.txt: extra entry not in the manifest",
        "d2/notes.txt: extra file not in the manifest",
        "d2/train-00000-of-00002.parquet: extra file not in the manifest "
        "(a shard the card does not list)",
    ]


def test_pictures_publish_json_does_not_list_are_reported(published_copy):
    _touch(published_copy / "pictures" / "d2" / "board_09999.svg", "<svg/>")
    _touch(published_copy / "pictures" / "d2-hard" / "pads.svg", "<svg/>")
    assert verify_set(published_copy) == [
        "pictures/d2-hard/pads.svg: extra file not listed in publish.json",
        "pictures/d2/board_09999.svg: extra file not listed in publish.json",
    ]


def test_a_board_entry_that_is_a_file_is_reported_not_a_crash(published_copy):
    board = published_copy / "d2" / "test" / "board_00002"
    for child in board.iterdir():
        child.unlink()
    board.rmdir()
    _touch(board)
    assert verify_set(published_copy) == ["d2/test/board_00002: not a folder"]

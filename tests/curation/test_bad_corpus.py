"""A PCBench checkout with broken entries: every entry gets a fate with its reason and is
counted; an unusable metadata.json keeps the board (attribution unknown) with a recorded note."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from pcbdata.curation import corpus
from pcbdata.model.kicad_writer import board_text
from pcbdata.sets.recipe import load_recipe
from tests.curation.corpus_fixture import _folder, final_json, fixture_recipe, row_board

UNKNOWN_ATTRIBUTION = "attribution unknown (licence NOASSERTION, not redistributable)"
EXPECTED = {  # name -> (fate, words of the reason)
    "alpha": ("kept", ""),
    "bravo_bad_metadata": ("kept", ""),
    "charlie_list_metadata": ("kept", ""),
    "delta_dangling_board": ("missing_input", "processed.kicad_pcb is a dangling symbolic link"),
    "echo_looping_final": ("load_failure", "final.json is a symbolic link loop"),
    "foxtrot_deep_final": ("load_failure", "final.json is nested too deeply to read"),
    "golf_author_list": ("kept", ""),
    "loop": ("load_failure", "PCBs/loop is a symbolic link loop"),
    "nowhere": ("missing_input", "PCBs/nowhere is a dangling symbolic link"),
    "stray.txt": ("missing_input", "PCBs/stray.txt is a file, not a board folder"),
}


def make_broken_corpus(root: Path) -> Path:
    boards = root / "PCBs"
    for k, name in enumerate(("alpha", "bravo_bad_metadata", "charlie_list_metadata",
                              "delta_dangling_board", "echo_looping_final",
                              "foxtrot_deep_final", "golf_author_list")):
        board = row_board(k + 1, f"broken/{name}")
        _folder(root, name, board_text(board).encode(), final_json(board),
                f"https://github.com/o/{name}")
    (boards / "bravo_bad_metadata" / "metadata.json").write_text('{"source": "https://gi')
    (boards / "charlie_list_metadata" / "metadata.json").write_text('["not", "an object"]')
    (boards / "delta_dangling_board" / "processed.kicad_pcb").unlink()
    (boards / "delta_dangling_board" / "processed.kicad_pcb").symlink_to("gone.kicad_pcb")
    (boards / "echo_looping_final" / "final.json").unlink()
    (boards / "echo_looping_final" / "final.json").symlink_to("final.json")
    (boards / "foxtrot_deep_final" / "final.json").write_text("[" * 100_000)
    meta = json.loads((boards / "golf_author_list" / "metadata.json").read_text())
    (boards / "golf_author_list" / "metadata.json").write_text(
        json.dumps({**meta, "author": ["a", "b"]}))
    (boards / "loop").symlink_to("loop", target_is_directory=True)
    (boards / "nowhere").symlink_to(root / "elsewhere", target_is_directory=True)
    (boards / "stray.txt").write_text("not a board\n")
    (boards / "master_metadata.json").write_text("{}")  # PCBench's own index: not an entry
    (root / "github_meta").mkdir()
    (root / "github_meta" / "github_1.json").write_text(json.dumps({"items": []}))
    (root / "github_meta" / "github_2.json").write_text("{truncated")
    (root / "LICENSE").write_text("MIT License\n")
    return root


@pytest.fixture(scope="module")
def broken(tmp_path_factory):
    root = tmp_path_factory.mktemp("broken")
    return {"source": make_broken_corpus(root / "src"),
            "recipe": load_recipe(fixture_recipe(root / "recipe.toml")), "root": root}


def test_every_entry_is_scanned_with_a_fate_and_reason(broken):
    boards = corpus.scan(broken["source"], broken["recipe"])
    assert [b.name for b in boards] == sorted(EXPECTED)
    for b in boards:
        fate, words = EXPECTED[b.name]
        assert (b.fate or "kept") == fate and words in b.reason, (b.name, b.fate, b.reason)


def test_unusable_metadata_is_a_note_and_the_board_goes_on(broken):
    by_name = {b.name: b for b in corpus.scan(broken["source"], broken["recipe"])}
    assert by_name["alpha"].notes == [] and by_name["alpha"].metadata
    bravo, charlie = by_name["bravo_bad_metadata"], by_name["charlie_list_metadata"]
    assert bravo.metadata is None and bravo.fate == ""
    assert bravo.notes == ["metadata.json is not valid JSON (Unterminated string starting at, "
                           f"line 1); {UNKNOWN_ATTRIBUTION}"]
    assert charlie.notes == [f"metadata.json is not a JSON object; {UNKNOWN_ATTRIBUTION}"]
    golf = by_name["golf_author_list"]  # the rest of its metadata is still used
    assert golf.notes == ["metadata.json: author not text, ignored"]
    assert golf.metadata["source"] == "https://github.com/o/golf_author_list"


def test_the_build_counts_every_entry_and_records_notes_and_warnings(broken, kicad_pool):
    from pcbdata.build.d3 import build

    out = broken["root"] / "out"
    log: list[str] = []
    summary = build(broken["source"], out, broken["recipe"], pool=kicad_pool, log=log.append)
    assert sum(summary["fates"].values()) == len(EXPECTED) == summary["boards"]
    with open(out / "curation_report.csv", newline="", encoding="utf-8") as handle:
        report = {r["name"]: r for r in csv.DictReader(handle)}
    assert {name: r["fate"] for name, r in report.items()} == {
        name: fate for name, (fate, _) in EXPECTED.items()}
    assert "not valid JSON" in report["bravo_bad_metadata"]["notes"]
    assert report["alpha"]["notes"] == ""
    doc = json.loads((out / "curation_report.json").read_text())
    assert doc["warnings"] == ["github_meta/github_2.json: skipped, not readable JSON "
                               "(JSONDecodeError)"]
    assert "d3: warning: bravo_bad_metadata: metadata.json is not valid JSON" in "\n".join(log)
    assert "d3: warning: github_meta/github_2.json: skipped" in "\n".join(log)
    with open(out / "attribution.csv", newline="", encoding="utf-8") as handle:
        attribution = {r["name"]: r for r in csv.DictReader(handle)}
    assert attribution["bravo_bad_metadata"]["licence"] == "NOASSERTION"
    assert attribution["bravo_bad_metadata"]["redistributable"] == "False"

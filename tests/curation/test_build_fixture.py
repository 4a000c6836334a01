"""`pcbdata build d3` on the fixture corpus: fates, outputs, determinism, resume."""
from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pcbdata.core.hashing import sha256_file
from pcbdata.core.tree import D3_STATE_DIR, REFERENCE_FILE
from tests.curation.corpus_fixture import EXPECTED_FATES, LEGACY

REPO = Path(__file__).resolve().parents[2]


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def tree(root: Path) -> dict[str, bytes]:
    """Every output file (state folder left out); the measured `seconds` blanked."""
    files = {}
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root).as_posix()
        if not path.is_file() or rel.startswith(".d3-state"):
            continue
        data = path.read_bytes()
        if path.name == "curation_report.csv":
            rows = read_csv(path)
            data = json.dumps([{k: v for k, v in r.items() if k != "seconds"} for r in rows]
                              ).encode()
        elif path.name == "curation_report.json":
            doc = json.loads(data)
            for board in doc["boards"]:
                board.pop("seconds")
            data = json.dumps(doc, sort_keys=True).encode()
        files[rel] = data
    return files


def test_every_fate_is_recorded_and_the_build_goes_on(fixture_build):
    report = read_csv(fixture_build["out"] / "curation_report.csv")
    assert {r["name"]: r["fate"] for r in report} == EXPECTED_FATES
    assert [r["name"] for r in report] == sorted(EXPECTED_FATES)
    by_name = {r["name"]: r for r in report}
    assert by_name["kilo_shorted"]["error_types"] == "tracks_crossing=2"
    assert by_name["lima_open"]["unconnected"] == "1"
    assert "final.json" in by_name["november_no_final"]["reason"]
    assert "UTF-8" not in by_name["quebec_bad_final"]["reason"]
    assert "JSON" in by_name["quebec_bad_final"]["reason"]
    assert by_name["sierra_excluded"]["reason"].startswith("fixture:")
    summary = fixture_build["summary"]
    assert summary["fates"]["kept"] == 10 and summary["fates"]["load_failure"] == 4
    assert any(line.startswith("d3: fates: ") for line in fixture_build["log"])
    assert any("kilo_shorted: drc_failure" in line for line in fixture_build["log"])


def test_board_bytes_identical_across_compat_pass_recorded(fixture_build):
    doc = json.loads((fixture_build["out"] / "curation_report.json").read_text())
    processed = [b for b in doc["boards"] if b["fate"] in ("kept", "drc_failure",
                                                           "not_connected")]
    assert processed and all(b["board_identical"] is True for b in processed)


def test_shipped_reference_is_the_board_file_the_compat_pass_left(fixture_build):
    """SPEC 3 step 2: the upgraded board file hashed as KiCad saved it, before the project
    pass, equals the file on disk after the pass, and the shipped reference is that file."""
    out = fixture_build["out"]
    states = [json.loads(p.read_text()) for p in (out / D3_STATE_DIR).glob("*.json")]
    compat = {s["name"]: s["compat"] for s in states if s["fate"] == "kept"}
    manifest = json.loads((out / "manifest.json").read_text())
    shipped = {board["name"]: sha256_file(out / config / split / board_id / REFERENCE_FILE)
               for config, entry in manifest["configs"].items()
               for split, data in entry["splits"].items()
               for board_id, board in data["boards"].items()}
    assert compat and set(shipped) == set(compat)
    for name, sha in shipped.items():
        assert compat[name]["board_sha256_before"] == compat[name]["board_sha256_after"] == sha


def test_characteristics_table_tiers_and_picks(fixture_build):
    rows = read_csv(fixture_build["out"] / "characteristics.csv")
    assert list(rows[0]) == ["board_id", "name", "nets", "components", "pads", "layers",
                             "tier", "in_test"]
    assert [(r["board_id"], r["tier"], r["in_test"]) for r in rows] == [
        ("0001_alpha", "A", "1"),
        ("0002_bravo board", "A", "1"),
        (f"0003_{LEGACY}", "A", "1"),
        ("0004_charlie (rev 2)", "B", "1"),
        ("0005_delta 'quoted'", "B", "0"),
        ('0006_echo "dq"', "B", "1"),
        ("0007_foxtrot", "B", "0"),
        ("0008_golf", "C", "1"),
        ("0009_hotel", "C", "0"),
        ("0010_india", "C", "1"),
    ]
    legacy = rows[2]
    assert (legacy["nets"], legacy["pads"], legacy["components"], legacy["layers"]) == \
        ("2", "4", "4", "2")


def test_board_files_and_manifest(fixture_build):
    out = fixture_build["out"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert set(manifest["configs"]) == {"d3-a", "d3-b", "d3-c"}
    recipe_sha = sha256_file(fixture_build["recipe_path"])
    counts = {}
    for config, entry in manifest["configs"].items():
        assert entry["recipe_sha256"] == recipe_sha and entry["recipe_version"] == \
            "2.0.0-fixture"
        assert entry["kicad_version"].startswith("9.0.8")
        assert len(entry["source"]["snapshot_sha256"]) == 64
        for split, data in entry["splits"].items():
            counts[(config, split)] = data["count"]
            for board_id, board in data["boards"].items():
                folder = out / config / split / board_id
                assert sorted(p.name for p in folder.iterdir()) == sorted(board["files"])
                for name, sha in board["files"].items():
                    assert sha256_file(folder / name) == sha
                src = fixture_build["source"] / "PCBs" / board["name"] / "processed.kicad_pcb"
                assert board["source_board_sha256"] == sha256_file(src)
    assert counts == {("d3-a", "test"): 3, ("d3-a", "full"): 3, ("d3-b", "test"): 2,
                      ("d3-b", "full"): 4, ("d3-c", "test"): 2, ("d3-c", "full"): 3}


def test_bare_board_reference_and_patched_project(fixture_build):
    folder = fixture_build["out"] / "d3-b" / "full" / "0004_charlie (rev 2)"
    bare = (folder / "board.kicad_pcb").read_text()
    reference = (folder / "reference.kicad_pcb").read_text()
    assert "(segment" not in bare and "(via" not in bare
    assert reference.count("(segment") == 3
    assert bare.count("(footprint") == reference.count("(footprint") == 6
    project = json.loads((folder / "board.kicad_pro").read_text())
    sev = project["board"]["design_settings"]["rule_severities"]
    assert sev["hole_clearance"] == "ignore" and sev["clearance"] == "error"
    legacy = fixture_build["out"] / "d3-a" / "full" / f"0003_{LEGACY}" / "board.kicad_pro"
    classes = json.loads(legacy.read_text())["net_settings"]["classes"]
    # Default clearance 0 in the KiCad 5 file -> the smallest copper spacing (pads 0.5 apart)
    assert [c["clearance"] for c in classes if c["name"] == "Default"] == [0.5]
    # its four footprints all had time stamp 0 (one UUID); they are made unique so that
    # KiCad's writer (which orders by UUID) saves them in a stable order
    ref = (legacy.parent / "reference.kicad_pcb").read_text()
    import re
    fp_uuids = re.findall(r'\n\t\(footprint [^\n]*\n\t\t\(layer [^\n]*\n\t\t\(uuid "([^"]+)"', ref)
    assert len(fp_uuids) == 4 and len(set(fp_uuids)) == 4
    doc = json.loads((fixture_build["out"] / "curation_report.json").read_text())
    assert {b["name"]: b["uuids_fixed"] for b in doc["boards"]}[LEGACY] >= 3


def test_attribution(fixture_build):
    out = fixture_build["out"]
    rows = {r["name"]: r for r in read_csv(out / "attribution.csv")}
    assert len(rows) == 10
    assert rows["bravo board"]["licence"] == "MIT"
    assert rows["bravo board"]["licence_from"] == "metadata.json"
    assert rows["alpha"]["licence"] == "GPL-3.0" and rows["alpha"]["licence_from"] == "github_meta"
    assert rows["alpha"]["author"] == "owner0"
    assert rows["india"]["licence"] == "NOASSERTION" and rows["india"]["redistributable"] == "False"
    assert all(r["collection_licence"] == "MIT" for r in rows.values())
    assert (out / "LICENSE-PCBench").read_text().startswith("MIT License")
    manifest = json.loads((out / "manifest.json").read_text())
    india = manifest["configs"]["d3-c"]["splits"]["full"]["boards"]["0010_india"]
    assert india["licence"] == "NOASSERTION" and india["redistributable"] is False
    assert india["pcbench_licence"] == "MIT"


def test_rebuild_in_place_reuses_state_and_changes_nothing(fixture_build, kicad_pool):
    from pcbdata.build.d3 import build
    from pcbdata.sets.recipe import load_recipe

    before = {p: (fixture_build["out"] / p).read_bytes() for p in tree(fixture_build["out"])}
    lines: list[str] = []
    build(fixture_build["source"], fixture_build["out"],
          load_recipe(fixture_build["recipe_path"]), pool=kicad_pool, log=lines.append)
    assert any("0 to process" in line for line in lines)
    after = {p: (fixture_build["out"] / p).read_bytes() for p in tree(fixture_build["out"])}
    assert after == before


def _cli(args: list[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "pcbdata", "build", "d3", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True, cwd=REPO)


@pytest.mark.slow
def test_sigkill_then_rerun_is_byte_identical(fixture_build, tmp_path):
    out = tmp_path / "killed"
    args = ["--source", str(fixture_build["source"]), "--out", str(out),
            "--recipe", str(fixture_build["recipe_path"]), "--workers", "1"]
    proc = _cli(args)
    states = out / ".d3-state"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if states.is_dir() and len(list(states.glob("*.json"))) >= 3:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the build ended before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)  # the build and its KiCad workers
    proc.wait()
    done_before = len(list(states.glob("*.json")))
    assert 3 <= done_before < 12  # 12 boards need KiCad (3 unbalanced files are refused before)
    assert not (out / "manifest.json").exists()

    proc = _cli(args)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode(errors="replace")[-2000:]
    assert f"{12 - done_before} to process" in err.decode()
    assert tree(out) == tree(fixture_build["out"])
    assert (out / "manifest.json").read_bytes() == \
        (fixture_build["out"] / "manifest.json").read_bytes()


def test_cli_reports_bad_source_as_user_error(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "pcbdata", "build", "d3", "--source",
                           str(tmp_path), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, cwd=REPO)
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("pcbdata: error:")
    assert "PCBench checkout" in proc.stderr


def test_time_limit_is_an_engine_failure_kept_under_the_same_limit(fixture_corpus, tmp_path):
    """A hang (here: a 0.01 s limit no KiCad task meets) becomes the board's fate; the build
    goes on and writes its outputs. The next run with the same limit does not pay for it
    again; a run with another limit does."""
    import shutil

    from pcbdata.build.d3 import build
    from pcbdata.sets.recipe import load_recipe

    src = tmp_path / "src"
    (src / "PCBs").mkdir(parents=True)
    shutil.copytree(fixture_corpus["source"] / "PCBs" / "alpha", src / "PCBs" / "alpha")
    shutil.copytree(fixture_corpus["source"] / "PCBs" / "mike_no_board",
                    src / "PCBs" / "mike_no_board")
    recipe_path = tmp_path / "recipe.toml"
    recipe_path.write_text(fixture_corpus["recipe_path"].read_text().replace(
        "task_timeout_s = 120", "task_timeout_s = 0.01"))
    summary = build(src, tmp_path / "out", load_recipe(recipe_path), workers=1,
                    log=lambda line: None)
    assert summary["fates"]["engine_failure"] == 1 and summary["fates"]["missing_input"] == 1
    rows = read_csv(tmp_path / "out" / "curation_report.csv")
    assert {r["name"]: r["fate"] for r in rows} == {"alpha": "engine_failure",
                                                    "mike_no_board": "missing_input"}
    assert "time limit" in rows[0]["reason"]
    assert (tmp_path / "out" / "manifest.json").is_file()
    lines: list[str] = []
    build(src, tmp_path / "out", load_recipe(recipe_path), workers=1, log=lines.append)
    assert any("0 to process" in line for line in lines)
    recipe_path.write_text(recipe_path.read_text().replace("task_timeout_s = 0.01",
                                                           "task_timeout_s = 0.02"))
    lines.clear()
    build(src, tmp_path / "out", load_recipe(recipe_path), workers=1, log=lines.append)
    assert any("1 to process" in line for line in lines)


def test_other_sets_in_the_folder_keep_their_manifest_entries(fixture_build, kicad_pool,
                                                             tmp_path):
    import shutil

    from pcbdata.build.d3 import build
    from pcbdata.sets.recipe import load_recipe

    out = tmp_path / "out"
    shutil.copytree(fixture_build["out"], out)
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["configs"]["d2"] = {"family": "d2", "splits": {}}
    (out / "manifest.json").write_text(json.dumps(manifest))
    build(fixture_build["source"], out, load_recipe(fixture_build["recipe_path"]),
          pool=kicad_pool, log=lambda line: None)
    after = json.loads((out / "manifest.json").read_text())
    assert set(after["configs"]) == {"d2", "d3-a", "d3-b", "d3-c"}
    assert after["configs"]["d3-a"] == manifest["configs"]["d3-a"]


def test_pcbdata_verify_accepts_the_built_set(fixture_build):
    proc = subprocess.run([sys.executable, "-m", "pcbdata", "verify", str(fixture_build["out"])],
                          capture_output=True, text=True, cwd=REPO)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "OK" in proc.stdout + proc.stderr

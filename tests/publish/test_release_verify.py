"""`pcbdata verify DIR --release` and `pcbdata.load(..., release=True)`: a set is compared with
the release manifests pinned in the package, so a board edited together with its manifest entry
(which still verifies against its own manifest) is caught and named."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import pcbdata
from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import sha256_file
from pcbdata.model.manifest import read_manifest, write_manifest
from pcbdata.publish import publish_set
from pcbdata.resources import resource_path
from pcbdata.sets.releases import check_release, pinned_release

EDITED = "d2/test/board_00005"


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A real small build: the whole D2 test split, and 4 of the 128 D1 g10 test boards."""
    root = tmp_path_factory.mktemp("release") / "set"
    assert main(["build", "d2", "--splits", "test", "--no-check", "--workers", "1",
                 "--out", str(root)]) == 0
    assert main(["build", "d1", "--grid", "10", "--splits", "test", "--count", "4", "--no-check",
                 "--workers", "1", "--out", str(root)]) == 0
    return root


@pytest.fixture
def built_copy(built, tmp_path):
    root = tmp_path / "set"
    shutil.copytree(built, root)
    return root


def _verify(root: Path, capsys, *flags: str) -> tuple[int, str]:
    capsys.readouterr()
    code = main(["verify", str(root), *flags])
    return code, capsys.readouterr().out


def _edit_board_and_its_entry(root: Path) -> None:
    """What a careless (or malicious) editor does: move a pad, fix the manifest, republish."""
    path = root / EDITED / "board.kicad_pcb"
    text = path.read_text()
    assert "(at 60 22.8)" in text
    path.write_text(text.replace("(at 60 22.8)", "(at 61.2 22.8)", 1))
    manifest = read_manifest(root)
    entry = manifest["configs"]["d2"]["splits"]["test"]["boards"]["board_00005"]
    entry["files"]["board.kicad_pcb"] = sha256_file(path)
    write_manifest(root, manifest)
    publish_set(root, previews=0)


def test_a_fresh_build_matches_its_pinned_releases(built, capsys):
    code, out = _verify(built, capsys, "--release")
    assert code == 0, out
    d2 = resource_path("releases", "d2.json.gz")
    assert (f"release d2 2.0.0 ({d2}): matches (subset of the release: test 128 of 128 boards; "
            f"not in this set: train, validation)") in out
    assert "release d1-g10 1.0.0 (" in out and "test 4 of 128 boards" in out
    assert out.rstrip().endswith(f"verify {built} --release: 132 boards in d1-g10, d2: OK")
    assert pcbdata.load("d2", split="test", root=built, release=True).num_rows == 128
    # a declared subset (the manifest's count is 4) loads: its rows are released boards
    assert pcbdata.load("d1-g10", split="test", root=built, release=True).num_rows == 4


def test_a_board_edited_with_its_manifest_entry_passes_verify_but_not_release(built_copy, capsys):
    _edit_board_and_its_entry(built_copy)
    code, out = _verify(built_copy, capsys)
    assert code == 0, out
    code, out = _verify(built_copy, capsys, "--release")
    assert code == 1
    assert f"{EDITED}: differs from the pinned release (board.kicad_pcb)" in out.splitlines()
    assert "release d2 2.0.0 (" in out and ": 1 difference(s)" in out
    assert "release d1-g10 1.0.0 (" in out and "d1-g10.json.gz): matches" in out
    with pytest.raises(UserError, match=f"{EDITED}: board.kicad_pcb altered .row sha256 differs "
                                        f"from the pinned release"):
        pcbdata.load("d2", split="test", root=built_copy, release=True)
    assert pcbdata.load("d2", split="test", root=built_copy).num_rows == 128  # off by default


def test_a_set_claiming_the_release_with_other_parameters_or_version_fails(built_copy, capsys):
    manifest = read_manifest(built_copy)
    manifest["configs"]["d2"]["parameters"]["min_pad_spacing_mm"] = 5.0
    manifest["configs"]["d2"]["set_version"] = "2.1.0"
    write_manifest(built_copy, manifest)
    publish_set(built_copy, previews=0)
    assert _verify(built_copy, capsys)[0] == 0
    code, out = _verify(built_copy, capsys, "--release")
    assert code == 1
    lines = out.splitlines()
    assert "d2: parameters.min_pad_spacing_mm is 5.0, the release has 4.8" in lines
    assert "d2: set_version is '2.1.0', the release has '2.0.0'" in lines
    with pytest.raises(UserError, match="rows say set_version '2.1.0', the release is '2.0.0'"):
        pcbdata.load("d2", split="test", root=built_copy, release=True)


def test_a_split_that_claims_all_boards_must_hold_them(built_copy, capsys):
    """Dropping a board from the set and its manifest is a subset only if the split says so."""
    shutil.rmtree(built_copy / "d2/test/board_00127")
    manifest = read_manifest(built_copy)
    del manifest["configs"]["d2"]["splits"]["test"]["boards"]["board_00127"]
    write_manifest(built_copy, manifest)
    publish_set(built_copy, previews=0)
    code, out = _verify(built_copy, capsys, "--release")
    assert code == 1
    assert ("d2/test/board_00127: in the pinned release but not in the set (its split claims "
            "all 128 boards)") in out.splitlines()
    assert "d2/test: count says 128 boards but the manifest lists 127" in out.splitlines()

    manifest["configs"]["d2"]["splits"]["test"]["count"] = 127  # now a declared subset
    write_manifest(built_copy, manifest)
    publish_set(built_copy, previews=0)
    code, out = _verify(built_copy, capsys, "--release")
    assert code == 0, out
    assert "subset of the release: test 127 of 128 boards" in out
    assert pcbdata.load("d2", split="test", root=built_copy, release=True).num_rows == 127


def test_without_a_manifest_the_rows_must_be_the_whole_released_split(built_copy):
    """A copy without `manifest.json` (as far as `load` knows, a Hub copy) cannot declare a
    subset: the 4 D1 rows are released boards, but not the released split."""
    (built_copy / "manifest.json").unlink()
    assert pcbdata.load("d2", split="test", root=built_copy, release=True).num_rows == 128
    with pytest.raises(UserError, match=r"124 problem\(s\): d1-g10/test/board_00004: in the "
                                        r"pinned release but not in the rows"):
        pcbdata.load("d1-g10", split="test", root=built_copy, release=True)


def test_a_config_without_a_pinned_release_is_an_error(tmp_path, capsys):
    root = tmp_path / "medium"
    assert main(["build", "d2", "--level", "medium", "--splits", "test", "--count", "2",
                 "--no-check", "--workers", "1", "--out", str(root)]) == 0
    assert _verify(root, capsys)[0] == 0
    code, out = _verify(root, capsys, "--release")
    assert code == 1
    assert ("d2-medium: no pinned release of this config in pcbdata (pinned: d2, d2r-a, d2r-b, "
            "d2r-c, d1-g10, d1-g50, d1-g100, d1-g200, d1-g500, d3-a, d3-b, d3-c); "
            "it cannot be checked with --release") in out
    with pytest.raises(UserError, match="d2-medium: no pinned release"):
        pcbdata.load("d2-medium", split="test", root=root, release=True)


def test_the_d3_releases_compare_board_by_board():
    """The D3 pins (splits test and full, reference boards, recipe) against themselves and
    against an edited copy: any routed reference or recipe change is named."""
    release = pinned_release("d3-b")
    manifest = json.loads(json.dumps(release.manifest))
    [check] = check_release(manifest)
    assert check.problems == [] and not check.subset
    assert check.compared == [("full", 285, 285), ("test", 10, 10)]
    full = manifest["configs"]["d3-b"]["splits"]["full"]["boards"]
    board_id = sorted(full)[3]
    full[board_id]["files"]["reference.kicad_pcb"] = "0" * 64
    full[board_id]["licence"] = "MIT" if full[board_id]["licence"] != "MIT" else "CC0-1.0"
    manifest["configs"]["d3-b"]["recipe"]["sha256"] = "1" * 64
    [check] = check_release(manifest)
    assert check.problems == [
        f"d3-b: recipe.sha256 is '{'1' * 64}', "
        f"the release has '{release.entry['recipe']['sha256']}'",
        f"d3-b/full/{board_id}: differs from the pinned release (reference.kicad_pcb, licence)",
    ]


def test_an_earlier_d3_release_is_checked_against_its_own_pin():
    """A set built with recipe 1.0.0 (`pcbdata build d3 --recipe d3-1.0.0`) verifies against
    the release of its set version, kept as `d3-b@1.0.0`, not against today's."""
    from pcbdata.sets.releases import released_configs

    old = pinned_release("d3-b", "1.0.0")
    assert old is not None and old.source.endswith("d3-b@1.0.0.json.gz")
    assert "d3-b@1.0.0" not in released_configs()
    [check] = check_release(json.loads(json.dumps(old.manifest)))
    assert check.problems == [] and check.compared == [("full", 286, 286), ("test", 10, 10)]
    assert pinned_release("d3-b", "9.9.9").version == "2.0.0"  # no such pin: today's


def test_a_declared_subset_may_hold_only_released_boards_and_no_more_than_the_release():
    release = pinned_release("d2")
    manifest = json.loads(json.dumps(release.manifest))
    test = manifest["configs"]["d2"]["splits"]["test"]
    kept = sorted(test["boards"])[:3]
    test["boards"] = {b: test["boards"][b] for b in kept}
    test["count"] = 3
    [check] = check_release(manifest)
    assert check.problems == [] and check.subset
    assert "test 3 of 128 boards" in check.line() and check.line().startswith("release d2 2.0.0 (")

    test["boards"]["board_99999"] = test["boards"][kept[0]]
    test["count"] = 4
    [check] = check_release(manifest)
    assert check.problems == ["d2/test/board_99999: not in the pinned release"]

    test["count"] = 129
    [check] = check_release(manifest)
    assert check.problems == ["d2/test: 129 boards, the pinned release has 128"]

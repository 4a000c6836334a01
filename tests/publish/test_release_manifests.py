"""The committed manifests of released sets (`pcbdata/resources/releases/`) match a rebuild of
their small splits:
a change that alters boards, splits or parameters cannot land unnoticed."""
from __future__ import annotations

from pathlib import Path

import pytest

from pcbdata.build import SyntheticOptions, build_configs
from pcbdata.model.manifest import read_manifest
from pcbdata.publish import verify_published
from pcbdata.sets.configs import get_config
from pcbdata.sets.releases import SUFFIX, VERSION_MARK, compare, read_release

MANIFESTS = Path(__file__).resolve().parents[2] / "pcbdata" / "resources" / "releases"
SYNTHETIC_FAMILIES = ("d1", "d2", "d2r")
SYNTHETIC = sorted(p for p in MANIFESTS.glob(f"*{SUFFIX}")
                   if VERSION_MARK not in p.name  # earlier releases (<config>@<version>)
                   and read_release(p)["configs"][p.name[: -len(SUFFIX)]]["family"]
                   in SYNTHETIC_FAMILIES)
SMALL = ["validation", "test"]


def _config(path: Path) -> str:
    return path.name[: -len(SUFFIX)]


@pytest.fixture(scope="module")
def rebuilt(tmp_path_factory):
    """The small splits of every released synthetic config, rebuilt from the config registry
    (no KiCad checks)."""
    root = tmp_path_factory.mktemp("rebuild") / "set"
    specs = [get_config(_config(p)) for p in SYNTHETIC]
    build_configs(root, specs, SyntheticOptions(splits=SMALL, check=False, workers=2))
    return root


def test_the_released_default_sets_are_committed():
    names = {_config(p) for p in SYNTHETIC}
    assert {"d1-g10", "d1-g50", "d1-g100", "d1-g200", "d1-g500", "d2",
            "d2r-a", "d2r-b", "d2r-c"} <= names
    for path in SYNTHETIC:
        release = read_release(path)
        entry = release["configs"][_config(path)]
        assert release["kicad_version"] == "9.0.8" and entry["set_version"]
        assert {s: entry["splits"][s]["count"] for s in entry["splits"]} == {
            "train": 10000, "validation": 128, "test": 128}
        assert all(len(b["files"]["board.kicad_pcb"]) == 64
                   for s in entry["splits"].values() for b in s["boards"].values())


@pytest.mark.parametrize("path", SYNTHETIC, ids=_config)
def test_rebuilt_small_splits_match_the_committed_manifest(rebuilt, path):
    problems = compare(read_release(path), read_manifest(rebuilt), _config(path), SMALL)
    assert problems == []


def test_the_rebuild_is_published_and_verifies(rebuilt):
    assert verify_published(rebuilt, read_manifest(rebuilt)) == []


def test_compare_names_changed_boards(rebuilt):
    path = MANIFESTS / f"d2{SUFFIX}"
    release = read_release(path)
    test = release["configs"]["d2"]["splits"]["test"]["boards"]
    test["board_00007"]["files"]["board.kicad_pcb"] = "0" * 64
    test["board_00009"]["n_pads"] += 1
    release["configs"]["d2"]["parameters"]["min_pad_spacing_mm"] = 5.0
    assert compare(release, read_manifest(rebuilt), "d2", SMALL) == [
        "d2: parameters changed: " + repr(release["configs"]["d2"]["parameters"]) + " -> "
        + repr(read_manifest(rebuilt)["configs"]["d2"]["parameters"]),
        "d2/test/board_00007: changed (board.kicad_pcb)",
        "d2/test/board_00009: changed (n_pads)",
    ]

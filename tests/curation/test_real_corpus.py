"""Real-corpus tier: a CI-sized subset of the shared PCBench snapshot, built with the packaged
recipe; pins each board's fate and the order of the characteristics table.

The snapshot is unpacked at run time from ../shared/pcbench/pcbench.tar.xz (never copied into
the repository). Set PCBDATA_REGEN_D3_PINS=1 to rewrite the pins after a deliberate change.
"""
from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import pytest

PINS = Path(__file__).parent / "data" / "real_subset_expected.json"


def _observed(real_subset) -> dict:
    with open(real_subset["out"] / "curation_report.csv", newline="", encoding="utf-8") as h:
        fates = {r["name"]: [r["fate"], r["error_types"]] for r in csv.DictReader(h)}
    with open(real_subset["out"] / "characteristics.csv", newline="", encoding="utf-8") as h:
        table = [[r["board_id"], r["pads"], r["nets"], r["components"], r["layers"], r["tier"],
                  r["in_test"]] for r in csv.DictReader(h)]
    return {"subset": real_subset["names"], "fates": fates, "characteristics": table,
            "summary": {"fates": real_subset["summary"]["fates"],
                        "tiers": real_subset["summary"]["tiers"]}}


@pytest.mark.slow
def test_real_subset_fates_and_table_are_pinned(real_subset):
    observed = _observed(real_subset)
    if os.environ.get("PCBDATA_REGEN_D3_PINS") == "1" or not PINS.is_file():
        PINS.write_text(json.dumps(observed, indent=1, sort_keys=True, ensure_ascii=False)
                        + "\n", encoding="utf-8")
        if os.environ.get("PCBDATA_REGEN_D3_PINS") != "1":
            pytest.fail(f"no pins yet: wrote {PINS}; review and commit it")
    expected = json.loads(PINS.read_text(encoding="utf-8"))
    assert observed["subset"] == expected["subset"]
    assert observed["fates"] == expected["fates"]
    assert observed["characteristics"] == expected["characteristics"]
    assert observed["summary"] == expected["summary"]


@pytest.mark.slow
def test_real_subset_reports_the_seven_missing_boards(real_subset):
    fates = _observed(real_subset)["fates"]
    missing = sorted(n for n, (fate, _) in fates.items() if fate == "missing_input")
    assert missing == ["Atreus_54percent_rev", "LargeWordClock_LargeKickstarter",
                       "ToslinkCNC_Toslink PlanetCNC ECO shield", "TurbiGnUSB_Turbidignusb",
                       "elec-power-bms_OSBMS Balancer Rev1", "elec-power-bms_rLoopPowerBms",
                       "pcb_HDMI2RGB_HDMI2RGB"]


@pytest.mark.slow
def test_real_subset_manifest_lists_every_file(real_subset):
    from pcbdata.core.hashing import sha256_file

    out = real_subset["out"]
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    n = 0
    for config, entry in manifest["configs"].items():
        for split, data in entry["splits"].items():
            folder = out / config / split
            assert sorted(p.name for p in folder.iterdir()) == sorted(data["boards"])
            for board_id, board in data["boards"].items():
                for name, sha in board["files"].items():
                    assert sha256_file(folder / board_id / name) == sha
                    n += 1
    assert n > 0


@pytest.mark.slow
def test_real_subset_boards_match_the_released_d3_manifests(real_subset):
    """Every kept board of the subset build has the bytes the committed release records:
    a change to the curation that alters a released board cannot land unnoticed."""
    import gzip

    from tests.conftest import REPO_ROOT

    released = {}
    for config in ("d3-a", "d3-b", "d3-c"):
        release = REPO_ROOT / "pcbdata" / "resources" / "releases" / f"{config}.json.gz"
        data = json.loads(gzip.decompress(release.read_bytes()))
        for board in data["configs"][config]["splits"]["full"]["boards"].values():
            released[board["name"]] = board["files"]
    built = json.loads((real_subset["out"] / "manifest.json").read_text())
    compared = 0
    for config in built["configs"].values():
        for board in config["splits"]["full"]["boards"].values():
            assert board["name"] in released, f"{board['name']}: kept here, not in the release"
            assert board["files"] == released[board["name"]], f"{board['name']}: files differ"
            compared += 1
    assert compared >= 100


RESTORED = ("LiPoSensor_lipo_sensor", "Kefersender_UKW TX", "MicroMaple_MicroMaple",
            "RGBMatrixPanelCPLD-PhotonBackpack_RGBMatrixPanel_CPLD")
ZERO_CLEARANCE = "hackaday_esp-14_power_meter__autosave-esp-14"


@pytest.mark.slow
def test_published_boards_with_open_connections_are_kept(real_subset):
    """SPEC section 3, step 3: unconnected items are no reason to drop a board."""
    with open(real_subset["out"] / "curation_report.csv", newline="", encoding="utf-8") as h:
        report = {r["name"]: r for r in csv.DictReader(h)}
    for name in RESTORED:
        assert report[name]["fate"] == "kept", name
    assert int(report["RGBMatrixPanelCPLD-PhotonBackpack_RGBMatrixPanel_CPLD"]["unconnected"]) \
        == 88
    assert not any(r["fate"] == "not_connected" for r in report.values())


@pytest.mark.slow
def test_zero_clearance_board_is_excluded_after_the_picks(real_subset):
    """SPEC section 3, step 8: only the curation report names it, as excluded."""
    out = real_subset["out"]
    with open(out / "curation_report.csv", newline="", encoding="utf-8") as h:
        report = {r["name"]: r for r in csv.DictReader(h)}
    assert report[ZERO_CLEARANCE]["fate"] == "excluded_by_override"
    assert report[ZERO_CLEARANCE]["board_id"] == ""
    for table in ("characteristics.csv", "attribution.csv"):
        assert ZERO_CLEARANCE not in (out / table).read_text(encoding="utf-8")
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    names = {b["name"] for c in manifest["configs"].values()
             for s in c["splits"].values() for b in s["boards"].values()}
    assert ZERO_CLEARANCE not in names
    notes = json.loads((out / "curation_report.json").read_text())["overrides"]
    assert {"kind": "exclude_after_picks", "board": ZERO_CLEARANCE,
            "applied": True}.items() <= next(n for n in notes
                                             if n["kind"] == "exclude_after_picks").items()


@pytest.mark.slow
def test_test_splits_are_the_published_picks(real_subset):
    """SPEC section 3, step 9: with every pinned board kept, D3-B and D3-C test are the
    published lists, and the manifest says so."""
    from pcbdata.sets.recipe import load_recipe

    published = load_recipe().published
    manifest = json.loads((real_subset["out"] / "manifest.json").read_text(encoding="utf-8"))
    for config in ("d3-b", "d3-c"):
        entry = manifest["configs"][config]
        test = sorted(b["name"] for b in entry["splits"]["test"]["boards"].values())
        assert test == sorted(published[config]), config
        assert entry["published_test"] is True
    assert real_subset["summary"]["warnings"] == []

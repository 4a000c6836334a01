"""`pcbdata build d2r` end to end: the manifest, byte-identical rebuilds, verify, load and the
card, overrides recorded, bad `--set` values refused, KiCad's check of the built boards, and
`pcbdata levels`."""
from __future__ import annotations

import json

import pytest

import pcbdata
from pcbdata.cli import main


def _build(out, *args) -> int:
    return main(["build", "d2r", "--splits", "test", "--workers", "1", "--out", str(out),
                 *map(str, args)])


def _files(root) -> dict:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and ".pcbdata" not in p.parts}


def test_build_writes_the_level_and_rebuilds_byte_identically(tmp_path, capsys):
    for name in ("a", "b"):
        assert _build(tmp_path / name, "--level", "a", "--count", "3", "--no-check") == 0
    assert "done: 3 boards" in capsys.readouterr().out
    assert _files(tmp_path / "a") == _files(tmp_path / "b")
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    config = manifest["configs"]["d2r-a"]
    assert config["family"] == "d2r" and config["level"] == "a" and config["overrides"] == {}
    assert config["parameters"]["components_median"] == 4.6
    assert config["parameters"]["top_up_by_pins"] == 1.0 and config["set_version"] == "4.0.0"
    assert config["parameters"]["packed_fraction"] == 0.2
    assert "d2r=3" in config["seed_scheme"]
    board = config["splits"]["test"]["boards"]["board_00000"]
    assert sorted(board["files"]) == ["board.kicad_dru", "board.kicad_pcb", "board.kicad_pro"]
    assert board["n_components"] >= 2 and board["n_layers"] in (2, 4)
    assert board["routing_layers"] == board["n_layers"]
    assert main(["verify", str(tmp_path / "a")]) == 0
    assert "3 boards in d2r-a: OK" in capsys.readouterr().out
    rows = pcbdata.load("d2r-a", split="test", root=str(tmp_path / "a"),
                        cache_dir=str(tmp_path / "cache"))
    assert len(rows) == 3 and rows[0]["board_id"] == "board_00000"
    assert "(footprint" in rows[0]["board"] and rows[0]["n_components"] >= 2
    card = (tmp_path / "a" / "README.md").read_text()
    assert "### D2R: realistic synthetic boards" in card and "pictures/d2r-a/" in card
    # One board beside a real board of the tier, with the real board's attribution.
    assert "![d2r-a beside a D3-A board](pictures/d2r-a/beside-d3-a.svg)" in card
    assert "`0057_tepmachcha_tepmachcha` of D3-A, by DAI-Maker-Lab" in card
    assert (tmp_path / "a" / "pictures" / "d2r-a" / "beside-d3-a.svg").stat().st_size > 10_000


def test_overrides_make_a_custom_config_recorded_in_the_manifest(tmp_path):
    out = tmp_path / "set"
    assert _build(out, "--level", "b", "--count", "2", "--no-check",
                  "--set", "components_median=10", "--set", "outline_mix={rounded=1.0}") == 0
    manifest = json.loads((out / "manifest.json").read_text())
    (name, config), = manifest["configs"].items()
    assert name.startswith("d2r-b-custom-")
    assert config["overrides"] == {"components_median": 10, "outline_mix": {"rounded": 1.0}}
    assert config["parameters"]["outline_mix"] == {"rounded": 1.0}
    text = (out / name / "test" / "board_00000" / "board.kicad_pcb").read_text()
    assert "(gr_arc" in text


@pytest.mark.parametrize("sets, message", [
    (["components_median=abc"], "is not a number, [list] or {table}"),
    (["components_median=many"], "is not a number"),
    (["component_median=5"], "did you mean 'components_median'"),
    (["components_median=1000"], "components_median must lie in components_range"),
    (["power_clearance_mm=0.3"], "above the library's smallest gap"),
    (["part_mix={passive=2}"], "part_mix probabilities must sum to 1"),
])
def test_bad_set_values_are_one_line_errors_and_write_nothing(tmp_path, capsys, sets, message):
    out = tmp_path / "set"
    args = [x for text in sets for x in ("--set", text)]
    assert _build(out, "--count", "2", "--no-check", *args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pcbdata: error: ") and "\n" not in err and message in err, err
    assert not out.exists()


def test_unknown_level_suggests_one(tmp_path, capsys):
    assert _build(tmp_path / "set", "--level", "bb", "--count", "1", "--no-check") == 2
    assert "did you mean 'b'" in capsys.readouterr().err


def test_built_boards_pass_the_kicad_check(tmp_path, capsys):
    out = tmp_path / "set"
    assert _build(out, "--level", "c", "--count", "1") == 0
    assert "1 checked in KiCad" in capsys.readouterr().out
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["configs"]["d2r-c"]["splits"]["test"]["kicad_checked"] == 1


def test_levels_lists_the_realistic_levels(capsys):
    assert main(["levels"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(" d2r-b " in line and "D3-B" in line for line in lines)
    assert main(["levels", "--json", "--family", "d2r"]) == 0
    table = json.loads(capsys.readouterr().out)
    assert sorted(table) == ["a", "b", "c"] and table["c"]["components_median"] == 53.0
    assert main(["levels", "--json"]) == 0  # D2's, as before
    assert "hard" in json.loads(capsys.readouterr().out)

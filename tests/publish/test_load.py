"""Every config and split of a published set loads with `datasets.load_dataset`, offline."""
from __future__ import annotations

import hashlib
import json

import datasets
import numpy as np
import pytest
import yaml

import pcbdata
from pcbdata.core.errors import UserError
from pcbdata.model.manifest import read_manifest
from pcbdata.publish import verify_published


def _card_yaml(root):
    return yaml.safe_load((root / "README.md").read_text().split("---\n")[1])


def test_every_config_and_split_loads_with_load_dataset(published):
    manifest = read_manifest(published)
    assert sorted(manifest["configs"]) == ["d1-g10", "d2", "d3-b"]
    for config, entry in manifest["configs"].items():
        for split, split_entry in entry["splits"].items():
            ds = datasets.load_dataset(str(published), config, split=split)
            boards = split_entry["boards"]
            assert sorted(ds["board_id"]) == sorted(boards), (config, split)
            assert set(ds["split"]) == {split} and set(ds["config"]) == {config}
            assert ds.features["board"] == datasets.Value("large_string")
            assert ds.features["project"] == datasets.Value("large_string")
            for row in ds:
                facts = boards[row["board_id"]]
                for key in ("n_nets", "n_pads", "n_components", "n_layers", "width_mm",
                            "height_mm"):
                    alias = {"n_nets": "nets", "n_pads": "pads", "n_components": "components",
                             "n_layers": "layers"}.get(key)
                    expected = facts.get(key, facts.get(alias))
                    assert row[key] == expected, (config, split, row["board_id"], key)
                assert row["sha256"] == facts["files"]["board.kicad_pcb"]
                assert row["set_version"] == entry["set_version"]
                assert json.loads(row["parameters"]) == entry["parameters"]
                if row["redistributable"]:
                    text = row["board"].encode()
                    assert hashlib.sha256(text).hexdigest() == row["sha256"]
    assert verify_published(published, manifest) == []


def test_card_yaml_has_configs_one_default_licence_and_metadata(published):
    meta = _card_yaml(published)
    configs = {c["config_name"]: c for c in meta["configs"]}
    assert [c for c in configs if configs[c].get("default")] == ["d2"]
    assert {s["split"] for s in configs["d3-b"]["data_files"]} == {"test", "full"}
    assert {s["split"] for s in configs["d2"]["data_files"]} == {"train", "validation", "test"}
    for entry in meta["configs"]:
        for item in entry["data_files"]:
            for path in item["path"]:
                assert (published / path).is_file()
                assert path.startswith(f"{entry['config_name']}/{item['split']}-")
                assert path.endswith(".parquet")
    # mixed licences (D3 boards keep theirs): "other" with a link to the attribution table
    assert meta["license"] == "other" and meta["license_link"] == "ATTRIBUTION.md"
    assert "pcb" in meta["tags"] and meta["size_categories"] == ["n<1K"] and meta["pretty_name"]
    body = (published / "README.md").read_text()
    for section in ("## Configs and splits", "## How the boards were made", "## Scoring",
                    "## Limitations", "## Attribution and licence", "## Citation", "## Pictures"):
        assert section in body
    from huggingface_hub import DatasetCard

    data = DatasetCard.load(published / "README.md").data  # the Hub's own parser accepts it
    assert data.license == "other" and data.pretty_name == meta["pretty_name"]
    assert [c["config_name"] for c in data.configs] == ["d2", "d1-g10", "d3-b"]
    infos = data.dataset_info
    assert {i["config_name"]: [s["num_examples"] for s in i["splits"]] for i in infos} == {
        "d2": [4, 2, 3], "d1-g10": [4, 2, 3], "d3-b": [2, 4]}
    attribution = (published / "ATTRIBUTION.md").read_text()
    assert "https://github.com/example/project_2" in attribution and "recipe" in attribution


def test_card_pictures_exist_histograms_and_previews(published):
    body = (published / "README.md").read_text()
    import re

    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", body)
    assert pictures and all((published / p).is_file() for p in pictures)
    assert "pictures/d2/pads.svg" in pictures and "pictures/d3-tiers-pads.svg" in pictures
    previews = [p for p in pictures if p.startswith("pictures/d2/board_")]
    assert len(previews) == 2
    assert "<svg" in (published / previews[0]).read_text()
    tiers = (published / "pictures/d3-tiers-pads.svg").read_text()
    assert "B | C (100 pads)" in tiers
    # no preview of a board that may not be redistributed
    assert not any("0003_project_2" in p for p in pictures)


def test_default_config_loads_without_a_name(published):
    ds = datasets.load_dataset(str(published), split="test")
    assert set(ds["config"]) == {"d2"}


def test_pcbdata_load_and_name_typos(published, monkeypatch):
    ds = pcbdata.load("d2", split="validation", root=published)
    assert isinstance(ds, datasets.Dataset) and len(ds) == 2
    monkeypatch.setenv("PCBDATA_ROOT", str(published))
    assert len(pcbdata.load("d1-g10", split="train")) == 4
    with pytest.raises(UserError, match=r"unknown config 'd1-g1'; did you mean 'd1-g10'\?"):
        pcbdata.load("d1-g1", root=published)
    with pytest.raises(UserError, match=r"unknown config 'd3b'; did you mean 'd3-b'\?"):
        pcbdata.load("d3b", root=published)
    with pytest.raises(UserError, match=r"unknown split 'tset'; did you mean 'test'\?"):
        pcbdata.load("d2", split="tset", root=published)
    with pytest.raises(UserError, match="unknown split 'train'.*splits: test, full"):
        pcbdata.load("d3-b", split="train", root=published)
    with pytest.raises(UserError, match="no such board set folder"):
        pcbdata.load("d2", root=published.parent / "nothing-here")
    with pytest.raises(UserError, match="cannot load someone/no-such-set"):
        pcbdata.load("d2", root="someone/no-such-set")  # a Hub id: offline here
    monkeypatch.delenv("PCBDATA_ROOT")
    with pytest.raises(UserError, match="no board set given"):
        pcbdata.load("d2")


def test_d1_rows_carry_the_connector_cells(published):
    ds = pcbdata.load("d1-g10", split="test", root=published)
    with np.load(published / "d1-g10" / "test.npz") as arrays:
        by_id = {str(b): k for k, b in enumerate(arrays["board_ids"])}
        for row in ds:
            k = by_id[row["board_id"]]
            assert row["starts"] == arrays["starts"][k].tolist()
            assert row["targets"] == arrays["targets"][k].tolist()
            assert row["grid_size"] == 10
    assert ds[0]["custom_rules"].startswith("(version 1)")


def test_recipe_rows_have_hashes_and_no_text(published):
    manifest = read_manifest(published)
    ds = pcbdata.load("d3-b", split="full", root=published)
    recipes = [row for row in ds if not row["redistributable"]]
    assert [r["board_id"] for r in recipes] == ["0003_project_2"]
    row = recipes[0]
    files = manifest["configs"]["d3-b"]["splits"]["full"]["boards"]["0003_project_2"]["files"]
    assert row["board"] is None and row["reference"] is None and row["project"] is None
    assert row["sha256"] == files["board.kicad_pcb"]
    assert row["reference_sha256"] == files["reference.kicad_pcb"]
    assert row["source_repository"] == "https://github.com/example/project_2"
    assert row["licence"] == "unknown" and row["author"] == "Author 2" and row["row"] == 3
    routed = [row for row in ds if row["redistributable"]]
    assert all(r["reference"] for r in routed)


def test_an_empty_split_verifies_and_loads_as_an_empty_dataset(tmp_path):
    """A small corpus can leave a D3 tier empty: no folders on disk, zero-row shards. `datasets`
    cannot read a split with no rows, so `pcbdata.load` returns an empty Dataset with the
    columns."""
    from pcbdata.model.manifest import write_manifest
    from pcbdata.publish import publish_set
    from pcbdata.sets.verify import verify_set
    from tests.publish.setbuilder import _d3_config, make_set

    manifest = make_set(tmp_path, d2={"test": 2}, d1={"test": 2}, d3=True)
    manifest["configs"]["d3-c"] = _d3_config(tmp_path, "d3-c", count=0)
    write_manifest(tmp_path, manifest)
    publish_set(tmp_path, previews=0)
    assert verify_set(tmp_path) == []
    empty = pcbdata.load("d3-c", split="full", root=tmp_path)
    full = pcbdata.load("d3-b", split="full", root=tmp_path)
    assert empty.num_rows == 0 and full.num_rows == 4
    assert {"config", "split", "board_id", "board", "project", "n_pads"} <= set(empty.column_names)
    assert set(empty.column_names) <= set(full.column_names)

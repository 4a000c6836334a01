"""Earlier versions of a level stay buildable byte for byte: the levels file as it was is kept
as `presets/<stem>@<version>.toml`, `pcbdata build d2r --level-version` reads it, and
`pcbdata verify --release` compares the result with that version's pinned release
(`releases/<config>@<version>.json.gz`)."""
from __future__ import annotations

import pytest

from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.generators.d2r import D2RParams
from pcbdata.model.manifest import read_manifest
from pcbdata.resources import resource_path
from pcbdata.sets.presets import level, level_versions
from pcbdata.sets.releases import compare, pinned_release, read_release, released_configs

SMALL = ["validation", "test"]


def test_the_levels_know_their_versions():
    assert level_versions("d2r", "b") == level_versions("d2r", "c") == [
        "6.0.0", "5.0.0", "4.0.0"]
    assert level_versions("d2r", "a") == ["4.0.0"]
    assert level("d2r", "b").version == "6.0.0"
    old = level("d2r", "b", version="4.0.0")
    assert old.version == "4.0.0" and old.params == D2RParams()  # 4.0.0: the defaults
    assert level("d2r", "a", version="4.0.0") == level("d2r", "a")
    assert level("d2r", "c").version == "6.0.0"
    assert level("d2r", "c").params.joint_correlation["fill:layers"] > 0
    assert level("d2r", "c", version="5.0.0").params.joint_correlation == {}
    assert level("d2r", "c", version="5.0.0").params.package_variety == 0.3
    assert level("d2r", "c", version="4.0.0").params.package_variety == 0.0
    with pytest.raises(UserError, match=r"no version '3.0.0' .*versions: 6.0.0, 5.0.0, 4.0.0"):
        level("d2r", "b", version="3.0.0")


def test_a_parameter_added_later_is_recorded_only_when_set():
    for name in ("land_pattern_spread", "land_pattern_library", "package_variety"):
        assert name not in D2RParams().as_dict()
        assert D2RParams(**{name: 0.5}).as_dict()[name] == 0.5
    assert "joint_correlation" not in D2RParams().as_dict()
    assert D2RParams(joint_correlation={"fill:power": 0.5}).as_dict()["joint_correlation"] == {
        "fill:power": 0.5}
    assert level("d2r", "b").params.as_dict()["land_pattern_spread"] == 0.8
    earlier = level("d2r", "b", version="5.0.0").params.as_dict()
    for name in ("package_variety", "land_pattern_library", "joint_correlation"):
        assert name not in earlier
    assert level("d2r", "c").params.as_dict()["package_variety"] == 0.3


def test_earlier_releases_are_kept_beside_the_current_ones():
    for config in ("d2r-b", "d2r-c"):
        for version in ("4.0.0", "5.0.0"):
            old = pinned_release(config, version)
            assert old is not None and old.source.endswith(f"{config}@{version}.json.gz")
            assert f"{config}@{version}" not in released_configs()
        new = pinned_release(config, "6.0.0")
        assert new is not None and new.version == "6.0.0"
        assert new.source.endswith(f"{config}.json.gz")
    assert pinned_release("d2r-a", "4.0.0").source.endswith("d2r-a.json.gz")


@pytest.mark.parametrize("name, version", [("b", "4.0.0"), ("c", "4.0.0"), ("b", "5.0.0"),
                                           ("c", "5.0.0")])
def test_an_earlier_level_version_rebuilds_its_pinned_release(tmp_path, capsys, name, version):
    """Levels b and c 4.0.0 and 5.0.0, rebuilt today (their validation and test splits), are
    the boards of their pinned releases, byte for byte, and `verify --release` takes them."""
    root = tmp_path / "set"
    assert main(["build", "d2r", "--level", name, "--level-version", version, "--splits",
                 ",".join(SMALL), "--no-check", "--workers", "2", "--out", str(root)]) == 0
    config = f"d2r-{name}"
    path = resource_path("releases", f"{config}@{version}.json.gz")
    assert compare(read_release(path), read_manifest(root), config, SMALL) == []
    capsys.readouterr()
    assert main(["verify", str(root), "--release"]) == 0
    out = capsys.readouterr().out
    assert f"release {config} {version} ({path}): matches" in out

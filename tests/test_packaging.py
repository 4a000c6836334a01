"""The installed package must contain every subpackage and the preset/recipe files."""
import tomllib

from tests.conftest import REPO_ROOT


def test_every_subpackage_is_listed_in_pyproject():
    pyproject = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())
    listed = set(pyproject["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(REPO_ROOT).parts)
               for p in (REPO_ROOT / "pcbdata").rglob("__init__.py")}
    missing = sorted(on_disk - listed)
    assert not missing, f"add to pyproject [tool.setuptools] packages: {missing}"


def test_presets_are_readable_as_package_data():
    from pcbdata.sets.presets import d1_preset, level

    assert d1_preset().grid_sizes == (10, 50, 100, 200, 500)
    assert level("d2", "default").version

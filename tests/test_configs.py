"""The config registry: every published config is listed with its family, version and seed
coupling, and names resolve (or fail with the closest known one)."""
import pytest

from pcbdata.core.errors import UserError
from pcbdata.sets.configs import get_config, registry
from pcbdata.sets.presets import d1_preset
from pcbdata.sets.presets import levels as preset_levels


def test_registry_lists_every_preset_grid_level_and_tier():
    names = set(registry())
    assert {f"d1-g{g}" for g in d1_preset().grid_sizes} <= names
    levels = {"d2" if n == "default" else f"d2-{n}" for n in preset_levels("d2")}
    assert levels <= names
    assert {"d3-a", "d3-b", "d3-c"} <= names


def test_d2_levels_share_one_stream_per_board_index():
    default, hard = get_config("d2").generator(), get_config("d2-hard").generator()
    # Same stream, different parameters: the first draw (board width) uses the same number.
    a, b = default.generate(0, "test", 3).board, hard.generate(0, "test", 3).board
    lo_a, hi_a = default.params.width_mm
    lo_b, hi_b = hard.params.width_mm
    fraction_b = (b.width / 1e6 - lo_b) / (hi_b - lo_b)
    assert (a.width / 1e6 - lo_a) / (hi_a - lo_a) == pytest.approx(fraction_b, abs=1e-4)
    assert "shared by every level" in get_config("d2-hard").seed_coupling


def test_any_d1_grid_resolves_and_unknown_names_suggest():
    spec = get_config("d1-g37-random-walk")
    assert (spec.grid, spec.placement, spec.family) == (37, "random-walk", "d1")
    with pytest.raises(UserError, match="did you mean 'd2-hard'"):
        get_config("d2-hardd")
    with pytest.raises(UserError, match="curated"):
        get_config("d3-a").generator()


def test_every_synthetic_config_makes_a_generator_of_the_protocol():
    from pcbdata.generators.base import Generator, SplitArrays

    for spec in registry().values():
        if not spec.synthetic:
            continue
        generator = spec.generator()
        assert isinstance(generator, Generator) and generator.family == spec.family
        assert isinstance(generator, SplitArrays) == (spec.family == "d1")
        assert set(spec.sizes) == set(spec.splits) and spec.seed is not None


def test_a_level_with_overrides_is_a_custom_config_generated_from_its_parameters():
    from pcbdata.sets.configs import level_config

    spec = level_config("d2", "hard", {"min_pad_spacing_mm": 3.6})
    assert spec.name.startswith("d2-hard-custom-") and len(spec.name) == len("d2-hard-custom-") + 8
    assert spec.parameters["min_pad_spacing_mm"] == 3.6
    assert spec.manifest["overrides"] == {"min_pad_spacing_mm": 3.6}
    assert spec.generator().params.min_pad_spacing_mm == 3.6
    assert level_config("d2", "hard", {"min_pad_spacing_mm": 3.6}).name == spec.name
    assert level_config("d2", "hard").name == "d2-hard"


def test_names_are_ordered_by_family_then_grid():
    from pcbdata.sets.configs import family_of, order_key

    names = ["d3-b", "d1-g500", "x", "d2-hard", "d1-g50-random-walk", "d1-g50", "d2", "d3-a"]
    assert sorted(names, key=order_key) == ["d2", "d2-hard", "d1-g50", "d1-g50-random-walk",
                                            "d1-g500", "d3-a", "d3-b", "x"]
    assert [family_of(n) for n in ("d1-g7", "d2-hard-custom-0123abcd", "d3-c", "x")] == [
        "d1", "d2", "d3", None]

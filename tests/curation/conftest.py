"""Session fixtures of the D3 curation tests: the fixture corpus and one build of it."""
from __future__ import annotations

import pytest

from tests.curation.corpus_fixture import fixture_recipe, make_corpus


@pytest.fixture(scope="session")
def fixture_corpus(tmp_path_factory):
    root = tmp_path_factory.mktemp("d3-fixture")
    make_corpus(root / "src")
    return {"source": root / "src", "recipe_path": fixture_recipe(root / "recipe.toml"),
            "root": root}


@pytest.fixture(scope="session")
def fixture_build(fixture_corpus, kicad_pool):
    """The fixture corpus built once (library call, shared engine pool)."""
    from pcbdata.build.d3 import build
    from pcbdata.sets.recipe import load_recipe

    out = fixture_corpus["root"] / "out"
    lines: list[str] = []
    summary = build(fixture_corpus["source"], out, load_recipe(fixture_corpus["recipe_path"]),
                    pool=kicad_pool, log=lines.append)
    from pcbdata.publish import publish_set

    publish_set(out, sorted(summary["tiers"]))  # as `pcbdata build d3` does
    return {"out": out, "summary": summary, "log": lines, **fixture_corpus}

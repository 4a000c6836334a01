"""D3 on Ray: the fixture corpus built with the Ray executor gives the same files as
the local build (`tree` blanks the measured seconds of curation_report.csv, as between two
local builds)."""
from __future__ import annotations

import pytest

from pcbdata.executors import RayExecutor
from tests.curation.test_build_fixture import tree


@pytest.mark.slow
def test_d3_on_ray_gives_the_local_build(fixture_build, ray_cluster, tmp_path):
    from pcbdata.build.d3 import build
    from pcbdata.publish import publish_set
    from pcbdata.sets.recipe import load_recipe

    out = tmp_path / "out"
    lines: list[str] = []
    summary = build(fixture_build["source"], out, load_recipe(fixture_build["recipe_path"]),
                    log=lines.append, executor=RayExecutor())
    publish_set(out, sorted(summary["tiers"]))
    assert any("to process with 2 workers" in line for line in lines)  # the cluster's CPUs
    assert summary["fates"] == fixture_build["summary"]["fates"]
    local, on_ray = tree(fixture_build["out"]), tree(out)
    assert on_ray.keys() == local.keys()
    assert [name for name in local if on_ray[name] != local[name]] == []

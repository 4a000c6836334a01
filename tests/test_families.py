"""A board family is one package and one call (`pcbdata.generators.families`): a toy family
written into a temporary folder is registered, and its one level is built (with its KiCad check
and publication), loaded as a dataset and routed in the environment, without touching pcbdata.
"""
from __future__ import annotations

import importlib
import sys
import textwrap

import pytest

from pcbdata.core.errors import UserError
from pcbdata.generators import families
from pcbdata.generators.base import Family

TOY_PACKAGE = '''
"""A toy family: D2's boards under another name, seed key and levels file."""
from pathlib import Path

from pcbdata.core.rng import SEED_SCHEME
from pcbdata.generators.base import Family
from pcbdata.generators.d2 import D2Generator, D2Params


class ToyGenerator(D2Generator):
    family = "toy"
    seed_key = 41


def _generator(parameters, manifest, where):
    return ToyGenerator(D2Params.from_dict(parameters, where))


FAMILY = Family(
    name="toy", seed_key=ToyGenerator.seed_key, params=D2Params, make_generator=_generator,
    capacities={"max_nets": 8, "max_pads": 32, "max_tracks": 512, "max_vias": 64,
                "max_outline_points": 16, "max_ratsnest": 32},
    title="Toy: two-net boards", text="Two nets of two pads on a 50 mm board.",
    seed_coupling="one stream per (split, index)", seed_scheme=SEED_SCHEME + "; toy=41",
    rank=5, levels_file=Path(__file__).with_name("levels.toml"), default_level="small")
'''

TOY_LEVELS = '''
version = "0.1.0"
seed = 3

[splits]
train = 4
validation = 2
test = 2

[levels.small]
rank = 0
description = "Two nets of two pads."
net_counts = [2]
pads_per_net = {2 = 1.0}
width_mm = [50.0, 50.0]
height_mm = [50.0, 50.0]
'''


@pytest.fixture
def toy_family(tmp_path, monkeypatch):
    package = tmp_path / "toyfamily"
    package.mkdir()
    (package / "__init__.py").write_text(textwrap.dedent(TOY_PACKAGE), encoding="utf-8")
    (package / "levels.toml").write_text(textwrap.dedent(TOY_LEVELS), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    # worker processes import the generator's module by name, as they would an installed one
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}:{__import__('os').environ.get('PYTHONPATH', '')}")
    module = importlib.import_module("toyfamily")
    table = dict(families._TABLE)
    families.register_family(module.FAMILY)
    yield module.FAMILY
    families._TABLE.clear()
    families._TABLE.update(table)
    sys.modules.pop("toyfamily", None)


def test_a_registered_family_is_built_loaded_and_routed(toy_family, tmp_path):
    from pcbdata.agents.registry import make_agent
    from pcbdata.build import SyntheticOptions, build_level
    from pcbdata.env.registry import make
    from pcbdata.publish.loading import load
    from pcbdata.runners.rollout import run_episode
    from pcbdata.sets.configs import family_of, get_config, order_key, registry

    assert "toy-small" not in registry() or get_config("toy-small").family == "toy"
    assert family_of("toy-small") == "toy" and order_key("toy-small")[0] == 0
    out = tmp_path / "set"
    summary = build_level(out, "toy", options=SyntheticOptions(
        splits=["test"], workers=1, log=lambda line: None))
    assert summary.line()
    manifest = __import__("json").loads((out / "manifest.json").read_text())
    entry = manifest["configs"]["toy"]
    assert entry["family"] == "toy" and entry["seed_scheme"].endswith("toy=41")
    card = (out / "README.md").read_text(encoding="utf-8")
    assert "### Toy: two-net boards" in card
    rows = load("toy", "test", root=str(out))
    assert len(rows) == 2
    env = make(out, "toy", split="test", drc="terminal")
    try:
        record = run_episode(env, make_agent("scripted", 0), rows[0]["board_id"], 0)
    finally:
        env.close()
    assert record["unconnected"] == 0 and not record["engine_failure"]


def test_a_family_cannot_take_another_ones_name_or_seed_key():
    d2 = families.family("d2")
    clash = Family(**{**d2.__dict__, "name": "d2x"})  # D2's seed key under another name
    with pytest.raises(UserError, match="seed key 2 is 'd2'"):
        families.register_family(clash)
    with pytest.raises(UserError, match="not d3"):
        families.register_family(Family(**{**d2.__dict__, "name": "d3", "seed_key": 99}))
    with pytest.raises(UserError, match="did you mean 'd2r'"):
        families.family("d2rr")

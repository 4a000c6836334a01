"""Every config a built set holds is an environment: a custom D2 level and a D1
placement, built by the build library as `pcbdata build` builds them, through `pcbdata
rollout` + `pcbdata eval`, `pcbdata.env.make`, the set id `pcbdata/Route-v2` and `check_env`;
the config's family and parameters come from the set's manifest, not from its name."""
from __future__ import annotations

import json
import shutil
import warnings

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env

import pcbdata.env
from pcbdata.cli import main
from pcbdata.core.errors import UserError

D2_CUSTOM = {"min_pad_spacing_mm": 4.0}


@pytest.fixture(scope="module")
def built_sets(tmp_path_factory) -> dict[str, tuple]:
    """{kind: (set folder, config name)}: a custom hard D2 level and D1 random-walk, 3 test
    boards each, with their manifests (no KiCad check, no publication: the boards are the
    generators' and the environment only reads them)."""
    from pcbdata.build import SyntheticOptions, build_d1, build_level
    from pcbdata.sets.configs import d1_config, level_config

    options = SyntheticOptions(splits=["test"], count=3, check=False, publish=False,
                               workers=1, log=lambda *_: None)
    d2_root, d1_root = tmp_path_factory.mktemp("d2c"), tmp_path_factory.mktemp("d1rw")
    build_level(d2_root / "set", "d2", "hard", D2_CUSTOM, options)
    build_d1(d1_root / "set", [10], "random-walk", options)
    return {"d2": (d2_root / "set", level_config("d2", "hard", D2_CUSTOM).name),
            "d1": (d1_root / "set", d1_config(10, "random-walk").name)}


def test_the_configs_are_outside_the_registry(built_sets):
    from pcbdata.sets.configs import registry

    names = [name for _, name in built_sets.values()]
    assert names[0].startswith("d2-hard-custom-") and names[1] == "d1-g10-random-walk"
    assert not set(names) & set(registry())


@pytest.mark.parametrize("kind", ["d2", "d1"])
def test_rollout_then_eval_on_a_set_config(kind, built_sets, tmp_path, capsys):
    root, config = built_sets[kind]
    runs = tmp_path / "runs"
    argv = ["rollout", str(root), "--config", config, "--agent", "scripted",
            "--max-steps", "30", "--workers", "1", "--drc", "terminal", "--out", str(runs)]
    assert main(argv) == 0, capsys.readouterr().err
    assert "done: 3 rollouts run" in capsys.readouterr().out
    for board in ("board_00000", "board_00001", "board_00002"):
        record = json.loads((runs / board / "0.json").read_text())
        assert record["env_id"] == pcbdata.env.SET_ENV_ID and record["config"] == config
        assert record["terminated"] or record["truncated"]  # the early end is an end
    report = tmp_path / "report"
    assert main(["eval", str(root), "--config", config, "--runs", str(runs), "--out",
                 str(report), "--k", "1", "--workers", "1"]) in (0, 1)
    rows = (report / "per_rollout.csv").read_text().splitlines()
    assert len(rows) == 4 and all(",ok," in row for row in rows[1:])


@pytest.mark.parametrize("kind", ["d2", "d1"])
def test_set_id_and_make_pass_check_env(kind, built_sets):
    root, config = built_sets[kind]
    for env in (gym.make(pcbdata.env.SET_ENV_ID, root=str(root), config=config),
                pcbdata.env.make(root, config, max_steps=20)):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                check_env(env.unwrapped)
        finally:
            env.close()


def test_the_manifest_gives_family_and_parameters(built_sets, tmp_path):
    """A set's config renamed to a name of no family still plays as what was built: D1's
    capacities and one-layer lattice from the recorded parameters, D2's custom parameters."""
    root, config = built_sets["d1"]
    renamed = tmp_path / "renamed"
    shutil.copytree(root, renamed)
    (renamed / config).rename(renamed / "my-boards")
    manifest = json.loads((renamed / "manifest.json").read_text())
    manifest["configs"]["my-boards"] = manifest["configs"].pop(config)
    (renamed / "manifest.json").write_text(json.dumps(manifest))
    env = pcbdata.env.make(renamed, "my-boards")
    try:
        obs, info = env.reset(seed=0)
        u = env.unwrapped
        assert u.config.family == "d1" and u.options.max_nets == 8
        assert u.static.grid_pitch == 10_000_000
        assert not info["action_mask"]["candidate_via"].any()
    finally:
        env.close()
    root, config = built_sets["d2"]
    env = pcbdata.env.make(root, config)
    try:
        spec = env.unwrapped.config
        assert spec.family == "d2" and spec.level == "hard"
        assert spec.parameters["min_pad_spacing_mm"] == 4.0 and spec.sizes == {"test": 3}
        assert env.unwrapped.options.max_nets == 32
    finally:
        env.close()


def test_an_unknown_config_names_the_configs_the_set_holds(built_sets, tmp_path, capsys):
    root, config = built_sets["d2"]
    with pytest.raises(UserError, match=f"holds no config 'd2' .*it holds: {config}"):
        pcbdata.env.make(root, "d2")
    with pytest.raises(UserError, match=f"it holds: {config}"):
        gym.make("pcbdata/Route-d2-v2", root=str(root))
    argv = ["rollout", str(root), "--config", "d2-hard", "--out", str(tmp_path / "r")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("pcbdata: error: ") and f"it holds: {config}" in err
    assert not (tmp_path / "r").exists()

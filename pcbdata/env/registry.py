"""Gymnasium ids of the routing environment.

- `pcbdata/Route-<config>-v2`: one per config of `pcbdata.sets.configs.registry()`, and its
  RL-wrapped twin `pcbdata/RouteRL-<config>-v2` (`pcbdata.env.wrappers.rl`).
- `pcbdata/Route-v2` and `pcbdata/RouteRL-v2`: any config, named by the `config` option, of
  the built set `root` (custom D2 levels such as `d2-hard-custom-<hash>`, D1 placements such
  as `d1-g10-random-walk`, D3 tiers): the config is what the set's manifest records, so no id
  has to be registered per set. `make(root, config, **options)` is the short form.

The version changes when the environment's dynamics, observation or reward change (or the
wrapper's spaces). Versions: 0, the first; 1, `push_n_shove` moves other nets' tracks (it was
masked) and the walkaround search stops on counted work (expansions, link checks) instead of
a 2 s clock; 2, the router keeps the rules' clearance exactly, `finish_episode()` ends an
episode early with the final DRC's correction as its last reward, a set's own configs
are environments, and (in the same release, so no new version) the default step limit scales
with the board (max(200, 8 x connections left at reset)), a failed step keeps the last good
board, `net_end` and push_n_shove delete dangling copper (`cleanup`), and vias reach inner
layers. Gymnasium answers a request for an older version by naming the current one.
"""
from __future__ import annotations

from pathlib import Path

import gymnasium as gym

NAMESPACE = "pcbdata"
VERSION = 2
ENTRY_POINT = "pcbdata.env.env:RoutingEnv"
RL_ENTRY_POINT = "pcbdata.env.wrappers.rl:make_rl_env"
#: The ids that take any config of a built set (`config=` and `root=` options).
SET_ENV_ID = f"{NAMESPACE}/Route-v{VERSION}"
SET_RL_ENV_ID = f"{NAMESPACE}/RouteRL-v{VERSION}"


def env_id(config: str, version: int = VERSION) -> str:
    return f"{NAMESPACE}/Route-{config}-v{version}"


def rl_env_id(config: str, version: int = VERSION) -> str:
    return f"{NAMESPACE}/RouteRL-{config}-v{version}"


def env_id_for(config: str) -> str:
    """The id to make `config` with: its own id when the registry has one, else the set id
    (`SET_ENV_ID`, with `config=` among the options)."""
    from pcbdata.sets.configs import registry

    return env_id(config) if config in registry() else SET_ENV_ID


def make(root, config: str, **options) -> gym.Env:
    """`gym.make` of any config the built set `root` holds (the set's manifest gives its
    family and parameters); `options` are the environment's keyword options. An unknown
    config is a `UserError` naming the configs the set holds."""
    register_all()
    return gym.make(SET_ENV_ID, root=str(Path(root)), config=config, **options)


def register_rl() -> list[str]:
    """Registers every config's RL-wrapped id and `SET_RL_ENV_ID` (idempotent); returns the
    per-config ids."""
    _register_one(SET_RL_ENV_ID, RL_ENTRY_POINT, {})
    return _register(rl_env_id, RL_ENTRY_POINT)


def register_all() -> list[str]:
    """Registers every config's id and `SET_ENV_ID` (idempotent); returns the per-config ids."""
    _register_one(SET_ENV_ID, ENTRY_POINT, {})
    return _register(env_id, ENTRY_POINT)


def _register(id_of, entry_point: str) -> list[str]:
    from pcbdata.sets.configs import registry

    ids = []
    for name in registry():
        ident = id_of(name)
        _register_one(ident, entry_point, {"config": name})
        ids.append(ident)
    return ids


def _register_one(ident: str, entry_point: str, kwargs: dict) -> None:
    if ident not in gym.registry:
        gym.register(id=ident, entry_point=entry_point, kwargs=kwargs, disable_env_checker=False)

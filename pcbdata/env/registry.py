"""One Gymnasium id per config of `pcbdata.configs.registry()`: `pcbdata/Route-<config>-v1`,
and its RL-wrapped twin `pcbdata/RouteRL-<config>-v1` (`pcbdata.env.rl`). The version changes
when the environment's dynamics, observation or reward change (or the wrapper's spaces).

Versions: 0, the first; 1, `push_n_shove` moves other nets' tracks (it was masked) and the
walkaround search stops on counted work (expansions, link checks) instead of a 2 s clock.
Gymnasium answers a request for an older version by naming the current one."""
from __future__ import annotations

import gymnasium as gym

NAMESPACE = "pcbdata"
VERSION = 1
ENTRY_POINT = "pcbdata.env.env:RoutingEnv"
RL_ENTRY_POINT = "pcbdata.env.rl:make_rl_env"


def env_id(config: str, version: int = VERSION) -> str:
    return f"{NAMESPACE}/Route-{config}-v{version}"


def rl_env_id(config: str, version: int = VERSION) -> str:
    return f"{NAMESPACE}/RouteRL-{config}-v{version}"


def register_rl() -> list[str]:
    """Registers every config's RL-wrapped id (idempotent); returns the ids."""
    return _register(rl_env_id, RL_ENTRY_POINT)


def register_all() -> list[str]:
    """Registers every config's id (idempotent); returns the ids."""
    return _register(env_id, ENTRY_POINT)


def _register(id_of, entry_point: str) -> list[str]:
    from pcbdata.configs import registry

    ids = []
    for name in registry():
        ident = id_of(name)
        if ident not in gym.registry:
            gym.register(id=ident, entry_point=entry_point, kwargs={"config": name},
                         disable_env_checker=False)
        ids.append(ident)
    return ids

"""One Gymnasium id per config of `pcbdata.configs.registry()`: `pcbdata/Route-<config>-v0`.
The version changes when the environment's dynamics, observation or reward change."""
from __future__ import annotations

import gymnasium as gym

NAMESPACE = "pcbdata"
VERSION = 0
ENTRY_POINT = "pcbdata.env.env:RoutingEnv"


def env_id(config: str, version: int = VERSION) -> str:
    return f"{NAMESPACE}/Route-{config}-v{version}"


def register_all() -> list[str]:
    """Registers every config's id (idempotent); returns the ids."""
    from pcbdata.configs import registry

    ids = []
    for name in registry():
        ident = env_id(name)
        if ident not in gym.registry:
            gym.register(id=ident, entry_point=ENTRY_POINT, kwargs={"config": name},
                         disable_env_checker=False)
        ids.append(ident)
    return ids

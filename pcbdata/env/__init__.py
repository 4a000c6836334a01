"""The routing environment (SPEC section 6): `import gymnasium as gym, pcbdata.env`, then
`gym.make("pcbdata/Route-d2-v2", root=SET, split="test")` (one id per config of
`pcbdata.sets.configs.registry()`), or `pcbdata.env.make(SET, CONFIG)` for any config a built set
holds (`gym.make("pcbdata/Route-v2", root=SET, config=CONFIG)`); see docs/env.md."""
from pcbdata.env.registry import (
    SET_ENV_ID,
    SET_RL_ENV_ID,
    env_id,
    make,
    register_all,
    register_rl,
    rl_env_id,
)
from pcbdata.env.types import ACTION_TYPES, ENGINE, MODES, PHASES

register_all()
register_rl()

__all__ = ["env_id", "make", "register_all", "rl_env_id", "register_rl", "SET_ENV_ID",
           "SET_RL_ENV_ID", "ACTION_TYPES", "MODES", "PHASES", "ENGINE"]

"""The routing environment (SPEC section 6): `import gymnasium as gym, pcbdata.env`, then
`gym.make("pcbdata/Route-d2-v1", root=SET, split="test")`. One id per config of
`pcbdata.configs.registry()`; see docs/env.md."""
from pcbdata.env.registry import env_id, register_all, register_rl, rl_env_id
from pcbdata.env.types import ACTION_TYPES, ENGINE, MODES, PHASES

register_all()
register_rl()

__all__ = ["env_id", "register_all", "rl_env_id", "register_rl", "ACTION_TYPES", "MODES",
           "PHASES", "ENGINE"]

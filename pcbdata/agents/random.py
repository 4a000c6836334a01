"""A masked random agent: uniform over the allowed action types, then over the allowed
arguments (seeded). It reads only `info["action_mask"]`."""
from __future__ import annotations

import numpy as np

from pcbdata.agents.scripted import action
from pcbdata.env.types import MAKE_VIA


class RandomAgent:
    """Uniform over allowed action types, then over allowed arguments (seeded)."""

    def __init__(self, seed: int = 0):
        self.rng = np.random.default_rng(seed)

    def _pick(self, mask: np.ndarray) -> int:
        allowed = np.flatnonzero(mask)
        return int(self.rng.choice(allowed)) if allowed.size else 0

    def act(self, obs, info) -> dict:
        m = info["action_mask"]
        kind = self._pick(m["type"])
        cands = m["candidate_via"] if kind == MAKE_VIA else m["candidate"]
        return action(kind, self._pick(m["net"]), self._pick(cands), self._pick(m["mode"]))

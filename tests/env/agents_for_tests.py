"""Agents for the rollout tests (importable by `--agent module:Class` in worker processes)."""
from __future__ import annotations

import os


class CrashingAgent:
    """Ends its process at the first action, as a policy that segfaults would."""

    def act(self, obs, info):
        os._exit(7)

"""An agent for the reference-routing tests (importable by `module:Class` in worker processes):
the bundled `scripted-shove`, except that it gives up at once on board_00001 (a board the
router does not complete) and ends its worker process on board_00002 (an engine failure)."""
from __future__ import annotations

import os

from pcbdata.agents.scripted import ShovingScriptedAgent


class GivesUpAndCrashes:
    def __init__(self, seed: int = 0):
        self.shove = ShovingScriptedAgent(seed=seed)
        self.gave_up = False

    @property
    def done(self) -> bool:
        return self.gave_up or self.shove.done

    def act(self, obs, info):
        if info["board_id"] == "board_00002":
            os._exit(7)  # as a policy that segfaults would
        if info["board_id"] == "board_00001":
            self.gave_up = True
        return self.shove.act(obs, info)


def claims_the_bare_board(root, config, split, board_id, agent, rollouts, env_options, target):
    """A reference task (`ReferencePlan.task`) that routes nothing: it writes the bare board as
    the reference and reports it routed, so only the build's KiCad check can catch it."""
    from pcbdata.core.fsutil import write_atomic
    from pcbdata.core.hashing import sha256_bytes
    from pcbdata.core.tree import BOARD_FILE, board_dir

    data = (board_dir(root, config, split, board_id) / BOARD_FILE).read_bytes()
    write_atomic(target, data)
    return {"status": "routed", "seed": 0, "env_id": "none", "sha256": sha256_bytes(data)}

"""The `policy` agent of `pcbdata rollout` (`--agent policy`: the shipped checkpoint;
`--agent policy:PATH`: any checkpoint). Every action comes from the network: argmax for
rollout 0, masked sampling seeded by the rollout number otherwise (the @k rollouts), with the
logits divided by the checkpoint's `sampling_temperature` (1 when it names none): a cloned
policy is so sure of itself that untempered samples repeat the argmax, and @k gains nothing.
A checkpoint trained without `finish` (`pcbdata train --no-finish`, its record's variant) never
sends it: the agent masks it out of what the environment offers, as training's environment
did."""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import torch

from pcbdata.core.hashing import sha256_file
from pcbdata.env.types import FINISH
from pcbdata.env.wrappers import features
from pcbdata.env.wrappers.rl import env_action
from pcbdata.learn import batch as batching
from pcbdata.learn.checkpoint import load_policy, shipped_path
from pcbdata.learn.derived import EpisodeReader
from pcbdata.learn.policy import device, to_tensors


@lru_cache(maxsize=8)
def _sha256_of(path: str, mtime_ns: int, size: int) -> str:
    return sha256_file(path)


def checkpoint_sha256(path: Path) -> str:
    """The checkpoint file's sha256 (memoised per file state: a worker makes one agent per
    rollout)."""
    stat = path.stat()
    return _sha256_of(str(path), stat.st_mtime_ns, stat.st_size)


class PolicyAgent:
    """Reads the environment's own observation and `info["action_mask"]`."""

    def __init__(self, seed: int = 0, path: str | None = None,
                 temperature: float | None = None):
        self.device = device()
        self.path = Path(path) if path is not None else shipped_path()
        self.policy, self.record = load_policy(self.path, self.device)
        self.greedy = seed == 0
        self.generator = torch.Generator(device=self.device).manual_seed(seed)
        self.temperature = float(self.record.get("sampling_temperature", 1.0)
                                 if temperature is None else temperature)
        self._layout: features.Layout | None = None
        self._static: features.StaticRows | None = None
        self.reader = EpisodeReader()
        self.no_finish = bool(self.record.get("variant", {}).get("no_finish", False))

    def identity(self) -> dict:
        """The checkpoint's sha256 and the sampling temperature (rollout 0 takes the argmax),
        for the rollout's `agent_identity`."""
        return {"checkpoint_sha256": checkpoint_sha256(self.path),
                "sampling": {"temperature": self.temperature}}

    def act(self, obs, info) -> dict:
        if int(obs["step"]) == 0 or self._layout is None:  # a new episode
            self._layout = batching.layout_of(obs)
            self._static = features.static_rows(obs, self._layout)
            self.reader.reset()
        masks = without_finish(info["action_mask"]) if self.no_finish else info["action_mask"]
        wrapped = batching.wrapped_observation(obs, masks, self._layout, self._static)
        return env_action(self.triple(wrapped))

    def triple(self, wrapped: dict) -> np.ndarray:
        """The (type, index, mode) the network picks for one RL-wrapper observation (the
        reader's memory records it as taken)."""
        items = batching.collate([batching.compact(wrapped, self.reader.read(wrapped))])
        with torch.no_grad():
            actions, _, _ = self.policy.act(to_tensors(items, self.device), self.greedy,
                                            self.generator, self.temperature)
        chosen = actions[0].cpu().numpy().astype(np.int64)
        self.reader.acted(chosen)
        return chosen


def without_finish(masks: dict) -> dict:
    """The environment's per-argument masks with `finish` masked, as the environment option
    finish=False gives them (the network's rows read the type mask too)."""
    types = np.array(masks["type"], copy=True)
    types[FINISH] = 0
    return {**masks, "type": types}

"""GRPO for `pcbdata train --algo grpo`: groups of rollouts of one board, advantages
normalised within the group, no critic (docs/learn.md).

Each update draws `groups` train boards (seeded by seed and update); every group plays `group`
whole episodes of its board with the current policy, sampled, in waves of `envs` vector
environments reset to that board (Gymnasium's autoreset off, so an environment whose episode
ended idles until the wave is over). An episode's advantage is its return's z-score within
its group, (R_i - mean R) / (std R + 1e-8), given to every step of the episode; the episode
return is Phi(s_T) - Phi(s_0) under either reward, so `--reward` does not change GRPO. The loss
is PPO's clipped ratio against the collecting policy over `ppo_epochs` epochs of minibatches,
each step weighted alike, minus the entropy bonus; no value term, no KL penalty.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from pcbdata.learn import batch as batching
from pcbdata.learn.derived import EpisodeReader
from pcbdata.learn.policy import to_tensors

#: Added to a group's standard deviation (a group of equal returns teaches nothing).
EPS = 1e-8


def group_advantages(returns: np.ndarray) -> np.ndarray:
    """The z-scores of one group's episode returns (population std; all zero when equal)."""
    returns = np.asarray(returns, dtype=np.float64)
    return (returns - returns.mean()) / (returns.std() + EPS)


@dataclass
class Episode:
    obs: list
    actions: list
    logp: list
    reward: float = 0.0


@dataclass
class Groups:
    """The steps of one update's groups, flat: observation, action, old log-probability and
    the advantage of the episode each belongs to."""

    obs: list
    actions: torch.Tensor
    logp: torch.Tensor
    advantages: np.ndarray
    returns: list  # every episode's return
    spreads: list  # every group's std of returns


def collect(policy, envs, s, update: int, dev) -> Groups:
    rng = np.random.default_rng(s.seed * 1_000_003 + update)
    gen = torch.Generator(device=dev).manual_seed(s.seed * 1_000_003 + update)
    obs, acts, logps, advs, returns, spreads = [], [], [], [], [], []
    for _ in range(s.groups):
        board = int(rng.integers(s.train_boards))
        episodes: list[Episode] = []
        while len(episodes) < s.group:
            seeds = [int(v) for v in rng.integers(2**31, size=envs.num_envs)]
            episodes += _wave(policy, envs, board, seeds, gen, dev)
        episodes = episodes[: s.group]
        totals = np.asarray([e.reward for e in episodes])
        for e, a in zip(episodes, group_advantages(totals), strict=True):
            obs += e.obs
            acts += e.actions
            logps += e.logp
            advs += [a] * len(e.obs)
        returns += totals.tolist()
        spreads.append(float(totals.std()))
    return Groups(obs, torch.stack(acts), torch.stack(logps), np.asarray(advs), returns,
                  spreads)


def _wave(policy, envs, board: int, seeds: list[int], gen, dev) -> list[Episode]:
    """One whole episode of `board` in every vector environment."""
    n = envs.num_envs
    raw, _ = envs.reset(seed=seeds, options={"index": board})
    readers = [EpisodeReader() for _ in range(n)]
    episodes = [Episode([], [], []) for _ in range(n)]
    live = np.ones(n, dtype=bool)
    while live.any():
        rows = np.flatnonzero(live)
        items = []
        for i in rows:
            one = {k: v[i] for k, v in raw.items()}
            items.append(batching.compact(one, readers[i].read(one)))
        with torch.no_grad():
            a, logp, _ = policy.act(to_tensors(batching.collate(items), dev), False, gen)
        chosen = np.zeros((n, 3), dtype=np.int64)  # idle for the environments that ended
        for j, i in enumerate(rows):
            chosen[i] = a[j].cpu().numpy()
            readers[i].acted(chosen[i])
            episodes[i].obs.append(items[j])
            episodes[i].actions.append(a[j].cpu())
            episodes[i].logp.append(logp[j].cpu())
        raw, r, term, trunc, _ = envs.step(chosen)
        for i in rows:
            episodes[i].reward += float(r[i])
        live &= ~(term | trunc)
    return episodes


def loss_of(policy, batch, actions, old, adv, s):
    """(loss, policy loss, entropy) of one minibatch: the clipped ratio, the entropy bonus."""
    logp, ent, _ = policy.evaluate(batch, actions)
    ratio = torch.exp(logp - old)
    pg = -torch.min(ratio * adv, ratio.clamp(1 - s.clip, 1 + s.clip) * adv).mean()
    return pg - s.entropy * ent.mean(), pg, ent.mean()

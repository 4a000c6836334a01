"""The routing environment for standard RL libraries (docs/env_rl.md).

`RLWrapper` turns the environment's nested observation into fixed-size arrays (one row per
entity, `pcbdata.env.wrappers.features`) and its Dict action into `MultiDiscrete([7, K, 3])`: (type,
index, mode), K = max(max_nets, max_candidates); the index is the net for `net_select`, the
candidate for `start_route` / `make_line` / `make_via`, ignored otherwise. `action_masks()`
returns the flat mask sb3-contrib's MaskablePPO takes for a MultiDiscrete space (the per-
dimension masks concatenated, 7 + K + 3 booleans); the observation carries the same mask and the
exact joint structure (`index_mask`, `mode_mask`: per action type) for libraries that mask
exactly. `make_vector_env` runs N wrapped environments in spawned worker processes.
"""
from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from pcbdata.env.types import (
    ACTION_TYPES,
    FINISH,
    MAKE_LINE,
    MAKE_VIA,
    MODES,
    NET_SELECT,
    START_ROUTE,
)
from pcbdata.env.wrappers import features

#: Action types whose index is the net / a candidate; types reading the mode.
NET_INDEXED = (NET_SELECT,)
CANDIDATE_INDEXED = (START_ROUTE, MAKE_LINE, MAKE_VIA)
MODED = (MAKE_LINE, MAKE_VIA, FINISH)
#: Bound of the real-valued features (normalised positions are about [-1, 1]; counts and codes).
LIMIT = 1e6
#: Keys of the flat `info` (always the same keys and types, so `gymnasium.vector` can batch it).
INFO_KEYS = ("board_id", "step", "phase", "net", "rejected", "router_ok", "router_reason",
             "unconnected", "drv", "phi", "wl_mm", "vias", "drc_fresh", "observation_cut",
             "engine_failure", "max_steps")


def index_size(options) -> int:
    return max(options.max_nets, options.max_candidates)


def observation_space(options) -> spaces.Dict:
    layout = features.Layout.from_options(options)
    rows, k = layout.rows, index_size(options)
    return spaces.Dict({
        "entities": spaces.Box(-LIMIT, LIMIT, (rows, len(features.COLUMNS)), np.float32),
        "entity_type": spaces.Box(0, len(features.FAMILIES) - 1, (rows,), np.int64),
        "entity_net": spaces.Box(-1, options.max_nets - 1, (rows, 2), np.int64),
        "entity_mask": spaces.MultiBinary(rows),
        "scale_mm": spaces.Box(0, LIMIT, (1,), np.float32),
        "action_mask": spaces.MultiBinary(len(ACTION_TYPES) + k + len(MODES)),
        "index_mask": spaces.MultiBinary((len(ACTION_TYPES), k)),
        "mode_mask": spaces.MultiBinary((len(ACTION_TYPES), len(MODES))),
    })


def joint_masks(masks: Mapping[str, np.ndarray], k: int) -> tuple[np.ndarray, np.ndarray]:
    """(index_mask [7, K], mode_mask [7, 3]) from the environment's per-argument masks: row t
    marks the indices / modes allowed with type t (all zeros for a masked type). A type that
    reads no index (or no mode) marks only 0, its canonical value; it accepts any."""
    n_types = len(ACTION_TYPES)
    index = np.zeros((n_types, k), dtype=np.int8)
    mode = np.zeros((n_types, len(MODES)), dtype=np.int8)
    for t in np.flatnonzero(masks["type"]):
        if t in NET_INDEXED:
            index[t, : len(masks["net"])] = masks["net"]
        elif t == MAKE_VIA:
            index[t, : len(masks["candidate_via"])] = masks["candidate_via"]
        elif t in CANDIDATE_INDEXED:
            index[t, : len(masks["candidate"])] = masks["candidate"]
        else:
            index[t, 0] = 1
        if t in MODED:
            mode[t] = masks["mode"]
        else:
            mode[t, 0] = 1
    return index, mode


def flat_mask(type_mask: np.ndarray, index: np.ndarray, mode: np.ndarray) -> np.ndarray:
    """MaskablePPO's mask for MultiDiscrete([7, K, 3]): type, then index, then mode, each the
    union over the allowed types (bool, length 7 + K + 3)."""
    return np.concatenate((type_mask.astype(bool), index.any(axis=0), mode.any(axis=0)))


def env_action(action) -> Any:
    """The environment's Dict action for a (type, index, mode) triple (a Dict action goes on
    unchanged). Something that is not three integers goes on as the type alone, so the
    environment rejects it with its reason."""
    if isinstance(action, Mapping):
        return action
    try:
        triple = np.asarray(action)
    except Exception:  # noqa: BLE001 - any object the agent sends
        return {"type": action}
    if triple.shape != (3,) or triple.dtype.kind not in "iu":
        return {"type": triple}
    kind, index, mode = (int(v) for v in triple)
    return {"type": kind, "net": index if kind in NET_INDEXED else 0,
            "candidate": index if kind in CANDIDATE_INDEXED else 0,
            "mode": mode if kind in MODED else 0}


def flat_info(info: dict) -> dict:
    """The keys of `INFO_KEYS`, each always of one type (str, int, float or bool)."""
    router = info.get("router") or {}
    return {"board_id": str(info.get("board_id", "")), "step": int(info.get("step", 0)),
            "phase": str(info.get("phase", "")), "net": str(info.get("net") or ""),
            "rejected": str(info.get("rejected") or ""),
            "router_ok": int(router["ok"]) if "ok" in router else -1,
            "router_reason": str(router.get("reason") or ""),
            "unconnected": int(info.get("unconnected", 0)), "drv": int(info.get("drv", 0)),
            "phi": float(info.get("phi", 0.0)), "wl_mm": float(info.get("wl_mm", 0.0)),
            "vias": int(info.get("vias", 0)), "drc_fresh": bool(info.get("drc_fresh", False)),
            "observation_cut": bool(info.get("observation_cut", False)),
            "max_steps": int(info.get("max_steps", 0)),
            "engine_failure": str(info.get("engine_failure") or "")}


class RLWrapper(gym.Wrapper):
    """Fixed-size entity arrays, a MultiDiscrete (type, index, mode) action and its masks.

    `info` is flat and type-stable (`INFO_KEYS`); the environment's own info of the last
    reset or step is `raw_info` (with `net_names` and `layers` after a reset)."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        options = env.unwrapped.options  # type: ignore[attr-defined]
        self.layout = features.Layout.from_options(options)
        self.index_size = index_size(options)
        self.observation_space = observation_space(options)
        self.action_space = spaces.MultiDiscrete([len(ACTION_TYPES), self.index_size,
                                                  len(MODES)])
        self._types = self.layout.types()
        self._flat = np.zeros(len(ACTION_TYPES) + self.index_size + len(MODES), dtype=np.bool_)
        self._flat[0] = True  # idle, before the first reset (steps then are rejected anyway)
        self.raw_info: dict = {}
        self._static: features.StaticRows | None = None

    def reset(self, *, seed=None, options=None):
        raw, info = self.env.reset(seed=seed, options=options)
        self._static = features.static_rows(raw, self.layout)  # the episode's fixed rows
        return self._observation(raw, info), self._info(info)

    def step(self, action):
        if self._static is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        raw, reward, terminated, truncated, info = self.env.step(
            env_action(action))
        return self._observation(raw, info), reward, terminated, truncated, self._info(info)

    def action_masks(self) -> np.ndarray:
        """The flat boolean mask MaskablePPO expects (length 7 + K + 3): a triple whose parts
        are each allowed may still be a masked combination (e.g. make_via at a candidate only
        make_line may use); it reaches the environment, which makes it a no-op with the reason
        in `info["rejected"]`. `obs["index_mask"]` / `obs["mode_mask"]` give the exact rows."""
        return self._flat.copy()

    def _info(self, info: dict) -> dict:
        self.raw_info = info
        return flat_info(info)

    def _observation(self, raw: dict, info: dict) -> dict:
        masks = info.get("action_mask") or self.env.unwrapped.action_masks()  # type: ignore
        index, mode = joint_masks(masks, self.index_size)
        self._flat = flat_mask(masks["type"], index, mode)
        limit = self.env.unwrapped.max_steps  # type: ignore[attr-defined] # the episode's
        table, nets, valid, frame = features.entity_table(raw, masks, self.layout, limit,
                                                          self._static)
        return {"entities": table, "entity_type": self._types.copy(), "entity_net": nets,
                "entity_mask": valid, "scale_mm": np.asarray([frame.scale], dtype=np.float32),
                "action_mask": self._flat.astype(np.int8), "index_mask": index,
                "mode_mask": mode}


def sample_action(obs: Mapping[str, np.ndarray], rng: np.random.Generator) -> np.ndarray:
    """A uniformly drawn allowed action from one observation's exact masks: a type, then an
    index and a mode of that type's rows (never a masked combination)."""
    types = np.flatnonzero(np.asarray(obs["index_mask"]).any(axis=1))
    kind = int(rng.choice(types))
    index = int(rng.choice(np.flatnonzero(obs["index_mask"][kind])))
    mode = int(rng.choice(np.flatnonzero(obs["mode_mask"][kind])))
    return np.asarray([kind, index, mode], dtype=np.int64)


def make_rl_env(config: str = "d2", runs_dir: str | None = None, boards=None, rollouts: int = 1,
                agent: str = "random", **options) -> gym.Env:
    """`RoutingEnv(config=..., **options)` wrapped by `RLWrapper`. With `runs_dir`, resets
    without options walk `boards` (ids; default all) `rollouts` times and each finished
    episode is written as `runs_dir/<board_id>/<rollout>.kicad_pcb` + JSON
    (`pcbdata.env.wrappers.recorder`)."""
    from pcbdata.env.env import RoutingEnv

    if boards is not None and runs_dir is None:
        from pcbdata.env.errors import EnvValueError

        raise EnvValueError("boards= schedules recorded episodes: give runs_dir= too")
    env: gym.Env = RLWrapper(RoutingEnv(config=config, **options))
    if runs_dir is not None:
        from pcbdata.env.wrappers.recorder import RunRecorder

        env = RunRecorder(env, runs_dir, boards, rollouts, agent)
    return env


def make_vector_env(config: str, n: int, boards=None, close_timeout: float | None = 60.0,
                    autoreset_mode: str = "NextStep", **options) -> gym.vector.AsyncVectorEnv:
    """N wrapped environments, each in its own spawned process with its own KiCad worker
    (`context="spawn"`: a process forked after KiCad ran DRC hangs). With `runs_dir` and
    `boards`, environment i records boards[i::n]. `autoreset_mode` is Gymnasium's ("Disabled":
    the caller resets, e.g. every environment to one board; a step after the end is the
    environment's no-op)."""
    if n < 1:
        from pcbdata.env.errors import EnvValueError

        raise EnvValueError(f"n={n}: need at least one environment")
    fns = []
    for i in range(n):
        share = list(boards)[i::n] if boards is not None else None
        fns.append(functools.partial(make_rl_env, config, boards=share, **options))
    return TimedCloseVectorEnv(fns, context="spawn", close_timeout=close_timeout,
                               autoreset_mode=autoreset_mode)


class TimedCloseVectorEnv(gym.vector.AsyncVectorEnv):
    """`AsyncVectorEnv` whose `close()` waits at most `close_timeout` seconds for a pending
    call before terminating its workers (Gymnasium's default waits without limit)."""

    def __init__(self, env_fns, close_timeout: float | None = 60.0, **kwargs):
        super().__init__(env_fns, **kwargs)
        self.close_timeout = close_timeout

    def close(self, **kwargs):
        kwargs.setdefault("timeout", self.close_timeout)
        super().close(**kwargs)

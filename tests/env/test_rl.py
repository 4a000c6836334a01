"""The RL wrapper (`pcbdata.env.wrappers.rl`): spaces, the flat (MaskablePPO) and exact masks
against the environment's own masks, masked combinations as no-ops, features invariant to
moving the board (a raw observation moved, and the same D2 board written moved and loaded by
KiCad), check_env, seeded determinism, the registered RouteRL ids and the run recorder."""
from __future__ import annotations

import dataclasses
import json
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import pcbdata.core.errors
import pcbdata.env  # noqa: F401 - registers the ids
from pcbdata.env.env import RoutingEnv
from pcbdata.env.types import ACTION_TYPES, MAKE_LINE, MAKE_VIA, MODES, NET_SELECT
from pcbdata.env.wrappers import features
from pcbdata.env.wrappers.rl import RLWrapper, env_action, make_rl_env, sample_action
from pcbdata.testing.sets import write_set


@pytest.fixture
def rl_env(board_set):
    made = []

    def factory(config: str = "d2", **options):
        options.setdefault("root", str(board_set))
        env = make_rl_env(config, **options)
        made.append(env)
        return env

    yield factory
    for env in made:
        env.close()


def _expected_flat(m: dict, k: int) -> np.ndarray:
    """The flat mask from the environment's per-argument masks, written out independently."""
    index = np.zeros(k, dtype=bool)
    index[0] = True  # idle is always allowed and takes index 0
    if m["type"][NET_SELECT]:
        index[: len(m["net"])] |= m["net"].astype(bool)
    if m["type"][3] or m["type"][MAKE_LINE]:
        index[: len(m["candidate"])] |= m["candidate"].astype(bool)
    if m["type"][MAKE_VIA]:
        index[: len(m["candidate_via"])] |= m["candidate_via"].astype(bool)
    mode = np.zeros(len(MODES), dtype=bool)
    mode[0] = True
    if m["type"][4:7].any():
        mode |= m["mode"].astype(bool)
    return np.concatenate((m["type"].astype(bool), index, mode))


def test_spaces_and_mask_form(rl_env):
    env = rl_env("d2", max_steps=40)
    k = max(env.unwrapped.options.max_nets, env.unwrapped.options.max_candidates)
    assert isinstance(env.action_space, gym.spaces.MultiDiscrete)
    assert env.action_space.nvec.tolist() == [len(ACTION_TYPES), k, len(MODES)]
    obs, info = env.reset(seed=3)
    rng = np.random.default_rng(0)
    phases = set()
    for _ in range(40):
        flat = env.action_masks()
        assert flat.dtype == np.bool_ and flat.shape == (int(env.action_space.nvec.sum()),)
        np.testing.assert_array_equal(flat, obs["action_mask"].astype(bool))
        np.testing.assert_array_equal(flat, _expected_flat(env.unwrapped.action_masks(), k))
        for part in np.split(flat, np.cumsum(env.action_space.nvec)[:-1]):
            assert part.any()  # MaskablePPO needs one allowed value per dimension
        assert env.observation_space.contains(obs)
        phases.add(info["phase"])
        obs, _, terminated, truncated, info = env.step(sample_action(obs, rng))
        assert info["rejected"] == "", info["rejected"]  # exact masks: never a masked action
        if terminated or truncated:
            break
    assert phases == {"no_net", "net", "routing"}


def _masked_combination(obs) -> tuple[int, int] | None:
    """(type, index) allowed by the flat mask part by part but not by the exact rows."""
    flat = obs["action_mask"].astype(bool)
    k = obs["index_mask"].shape[1]
    for kind in (NET_SELECT, 3, MAKE_LINE, MAKE_VIA):
        if not flat[kind]:
            continue
        bad = np.flatnonzero(flat[7:7 + k] & ~obs["index_mask"][kind].astype(bool))
        if len(bad):
            return kind, int(bad[0])
    return None


def test_a_masked_combination_is_a_noop_with_the_reason(rl_env):
    env = rl_env("d2", max_steps=60)
    obs, _ = env.reset(seed=1)
    rng = np.random.default_rng(1)
    seen = set()
    for _ in range(60):
        found = _masked_combination(obs)
        if found and found[0] not in seen:
            seen.add(found[0])
            before = obs
            phi = env.unwrapped._state["phi"]
            obs, reward, _, _, info = env.step(np.asarray([found[0], found[1], 0]))
            assert info["rejected"], found
            assert reward == 0.0 and env.unwrapped._state["phi"] == phi
            for key in ("entity_mask", "index_mask", "action_mask"):
                np.testing.assert_array_equal(obs[key], before[key])
            continue
        obs, _, terminated, truncated, _ = env.step(sample_action(obs, rng))
        if terminated or truncated:
            break
    assert {NET_SELECT, MAKE_LINE} <= seen, seen


def test_malformed_actions_are_noops(rl_env):
    env = rl_env("d2")
    with pytest.raises(gym.error.ResetNeeded):
        env.step([0, 0, 0])
    with pytest.raises(pcbdata.core.errors.UserError, match="runs_dir"):
        rl_env("d2", boards=["board_00000"])
    env.reset(seed=0)
    for bad in ([1, 2], np.asarray([1.5, 0, 0]), "net_select", [1, 10**6, 0], [9, 0, 0]):
        _, reward, terminated, truncated, info = env.step(bad)
        assert info["rejected"].startswith("malformed action"), (bad, info["rejected"])
        assert reward == 0.0 and not terminated and not truncated
    assert env_action([1, 5, 2]) == {"type": 1, "net": 5, "candidate": 0, "mode": 0}
    assert env_action([5, 7, 1]) == {"type": 5, "net": 0, "candidate": 7, "mode": 1}


def test_feature_columns_follow_the_observation():
    """features.py reads the raw observation's columns by position: these are the ones."""
    from pcbdata.env.observation import COLUMNS

    assert COLUMNS == {
        "outline": ("x", "y", "ring"),
        "nets": ("valid", "pads", "clearance", "track_width", "via_diameter", "via_drill"),
        "pads": ("valid", "net", "x", "y", "size_x", "size_y", "shape", "drill"),
        "tracks": ("valid", "net", "layer", "arc", "x1", "y1", "x2", "y2", "width"),
        "vias": ("valid", "net", "x", "y", "diameter", "drill"),
        "ratsnest": ("valid", "net", "x1", "y1", "x2", "y2"),
        "candidates": ("kind", "x", "y", "layer"),
        "violations": ("valid", "type", "severity", "x", "y", "net_a", "net_b")}


# ---- invariance to moving the board --------------------------------------------------------

SHIFT = (13.5, -7.25)  # mm
POSITIONS = {("board_static", "outline"): [(0, 1)], ("board_static", "pads"): [(2, 3)],
             ("routing_geometry", "tracks"): [(4, 5), (6, 7)],
             ("routing_geometry", "vias"): [(2, 3)],
             ("routing_geometry", "ratsnest"): [(2, 3), (4, 5)],
             ("router_head", "candidates"): [(1, 2)], ("drc", "violations"): [(3, 4)]}
VALID_COLUMN = {"outline": None, "candidates": 0}


def _moved(raw: dict, dx: float, dy: float) -> dict:
    """A deep copy of a raw observation with every position moved by (dx, dy) mm."""
    out = {k: ({kk: np.array(vv, copy=True) for kk, vv in v.items()} if isinstance(v, dict)
               else np.array(v, copy=True)) for k, v in raw.items()}
    for (part, name), pairs in POSITIONS.items():
        rows = out[part][name]
        if name == "outline":
            live = np.arange(len(rows)) < int(out[part]["outline_count"])
        else:
            live = rows[:, 0] != 0
        for cx, cy in pairs:
            rows[live, cx] += dx
            rows[live, cy] += dy
    if int(out["router_head"]["layer"]) >= 0:
        out["router_head"]["position"] += (dx, dy)
    return out


COORDINATE_FREE = [c for c in range(len(features.COLUMNS)) if c not in features.POSITION_COLUMNS]


def test_features_of_a_moved_raw_observation_are_the_same(board_set):
    env = RoutingEnv(config="d2", root=str(board_set), max_steps=30)
    layout = features.Layout.from_options(env.options)
    try:
        raw, info = env.reset(seed=2)
        rng = np.random.default_rng(2)
        wrapper = RLWrapper(env)
        obs = wrapper._observation(raw, info)
        static = features.static_rows(raw, layout)  # the episode's cache, as the wrapper keeps
        checked = 0
        for _ in range(30):
            masks = info["action_mask"]
            table, nets, valid, frame = features.entity_table(raw, masks, layout, 30)
            cached = features.entity_table(raw, masks, layout, 30, static)
            for x, y in zip(cached[:3], (table, nets, valid), strict=True):
                np.testing.assert_array_equal(x, y)
            moved = _moved(raw, *SHIFT)
            assert not np.array_equal(moved["board_static"]["pads"], raw["board_static"]["pads"])
            t2, n2, v2, f2 = features.entity_table(moved, masks, layout, 30)
            assert (f2.cx, f2.cy) == pytest.approx((frame.cx + SHIFT[0], frame.cy + SHIFT[1]))
            np.testing.assert_array_equal(v2, valid)
            np.testing.assert_array_equal(n2, nets)
            np.testing.assert_array_equal(t2[:, COORDINATE_FREE], table[:, COORDINATE_FREE])
            np.testing.assert_allclose(t2, table, atol=1e-6)
            assert np.abs(table[valid == 1][:, features.X1]).max() > 0.3  # not all at the centre
            checked += int(valid.sum())
            raw, _, terminated, truncated, info = env.step(env_action(sample_action(obs, rng)))
            obs = wrapper._observation(raw, info)
            if terminated or truncated:
                break
        assert checked > 0
    finally:
        env.close()


def _write_moved_set(root, dx_mm: float, dy_mm: float) -> None:
    """Board 0 of D2's test split, written as `pcbdata build` writes it but moved: pads shifted
    in the board model, the Edge.Cuts rectangle shifted in the text."""
    from pcbdata.model.board import mm_to_nm, nm_to_mm
    from pcbdata.model.kicad_writer import board_files
    from pcbdata.sets.configs import get_config

    spec = get_config("d2")
    instance = spec.generator().generate(spec.seed, "test", 0)
    dx, dy = mm_to_nm(dx_mm), mm_to_nm(dy_mm)
    board = instance.board
    moved = dataclasses.replace(board, pads=[dataclasses.replace(p, x=p.x + dx, y=p.y + dy)
                                             for p in board.pads])
    folder = root / "d2" / "test" / instance.board_id
    folder.mkdir(parents=True)
    w, h = nm_to_mm(board.width), nm_to_mm(board.height)
    for name, text in board_files(moved).items():
        if name.endswith(".kicad_pcb"):
            rect = f"(start 0 0)\n\t\t(end {_fmt(w)} {_fmt(h)})"
            assert rect in text
            text = text.replace(rect, f"(start {_fmt(dx_mm)} {_fmt(dy_mm)})\n\t\t(end "
                                      f"{_fmt(w + dx_mm)} {_fmt(h + dy_mm)})")
        (folder / name).write_text(text, encoding="utf-8")


def _fmt(value: float) -> str:
    from pcbdata.model.kicad_writer import mm

    return mm(round(value * 1e6))


def test_the_same_board_written_moved_gives_the_same_features(tmp_path):
    """KiCad loads both boards; the same actions give the same features and rewards."""
    write_set(tmp_path / "here", "d2", "test", 1)
    _write_moved_set(tmp_path / "moved", *SHIFT)
    envs = [make_rl_env("d2", root=str(tmp_path / name), max_steps=40) for name in ("here",
                                                                                   "moved")]
    try:
        (a, _), (b, _) = (e.reset(seed=0) for e in envs)
        pads = [e.unwrapped.static.pads[0] for e in envs]  # KiCad's own positions differ
        assert (pads[1].x - pads[0].x, pads[1].y - pads[0].y) == (13_500_000, -7_250_000)
        assert a["scale_mm"] == b["scale_mm"]
        rng = np.random.default_rng(5)
        for _ in range(40):
            _same(a, b)
            action = sample_action(a, rng)
            a, ra, ta, xa, ia = envs[0].step(action)
            b, rb, tb, xb, ib = envs[1].step(action)
            assert (ra, ta, xa) == pytest.approx((rb, tb, xb), abs=1e-9)
            assert (ia["rejected"], ia["unconnected"], ia["drv"]) == \
                (ib["rejected"], ib["unconnected"], ib["drv"])
            if ta or xa:
                break
        assert ia["wl_mm"] > 0  # the actions routed copper
    finally:
        for e in envs:
            e.close()


def _same(a: dict, b: dict) -> None:
    for key in ("entity_type", "entity_net", "entity_mask", "action_mask", "index_mask",
                "mode_mask"):
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    np.testing.assert_array_equal(a["entities"][:, COORDINATE_FREE],
                                  b["entities"][:, COORDINATE_FREE])
    np.testing.assert_allclose(a["entities"], b["entities"], atol=1e-6)


# ---- gymnasium's checks, determinism, ids ---------------------------------------------------

@pytest.mark.parametrize("config", ["d1-g10", "d2"])
def test_check_env_passes(board_set, config):
    """On the registered RL id as gym.make returns it (the one warning ignored is check_env's
    note that the wrapper is not the unwrapped environment)."""
    env = gym.make(f"pcbdata/RouteRL-{config}-v2", root=str(board_set))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            warnings.filterwarnings("ignore", message=".*different from the unwrapped version")
            check_env(env)
    finally:
        env.close()


def _trace(env, seed: int, steps: int) -> list:
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    out = [(obs, info)]
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(sample_action(obs, rng))
        out.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            break
    return out


def test_seeded_runs_are_identical(rl_env):
    first, second = (_trace(rl_env("d2"), 11, 25) for _ in range(2))
    assert len(first) == len(second)
    for x, y in zip(first, second, strict=True):
        for a, b in zip(x, y, strict=True):
            if isinstance(a, dict) and isinstance(next(iter(a.values())), np.ndarray):
                for key in a:
                    np.testing.assert_array_equal(a[key], b[key])
            else:
                assert a == b


def test_registered_ids(board_set):
    env = gym.make("pcbdata/RouteRL-d2-v2", root=str(board_set))
    try:
        obs, info = env.reset(seed=0)
        flat = env.get_wrapper_attr("action_masks")()
        np.testing.assert_array_equal(flat, obs["action_mask"].astype(bool))
        assert isinstance(env.unwrapped, RoutingEnv)
        assert set(pcbdata.env.register_rl()) <= set(gym.registry)
    finally:
        env.close()


def test_the_recorder_writes_runs_eval_reads(rl_env, tmp_path):
    runs = tmp_path / "runs"
    env = rl_env("d2", runs_dir=str(runs), boards=["board_00001", "board_00002"], rollouts=1,
                 max_steps=8)
    obs, info = env.reset(seed=0)
    assert info["board_id"] == "board_00001" and info["scheduled_left"] == 2
    rng = np.random.default_rng(0)
    ended = []
    while len(ended) < 3:
        obs, _, terminated, truncated, info = env.step(sample_action(obs, rng))
        if terminated or truncated:
            ended.append(info["board_id"])
            obs, info = env.reset()
    assert ended[:2] == ["board_00001", "board_00002"]
    written = sorted(p.relative_to(runs).as_posix() for p in runs.rglob("*") if p.is_file())
    assert written == ["board_00001/0.json", "board_00001/0.kicad_pcb", "board_00002/0.json",
                       "board_00002/0.kicad_pcb"]
    record = json.loads((runs / "board_00002" / "0.json").read_text())
    assert record["steps"] == 8 and record["truncated"] and record["time_s"] > 0

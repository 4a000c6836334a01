"""`render_mode="rgb_array"`: the environment's state as a picture (`pcbdata.core.drawing`): copper
per layer in its colour, ratsnest lines while pads are open, the head, DRC markers; identical
bytes for identical states; Gymnasium's checker with the render mode."""
from __future__ import annotations

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from pcbdata.agents.scripted import ScriptedAgent
from pcbdata.core import drawing
from pcbdata.env.errors import EnvValueError
from pcbdata.env.viewer import RENDER_SIZE


def count(image: np.ndarray, colour) -> int:
    return int(np.all(image == np.asarray(colour, dtype=np.uint8), axis=-1).sum())


def pad_candidates(obs, info) -> list[int]:
    rows, mask = obs["router_head"]["candidates"], info["action_mask"]["candidate"]
    return [i for i in range(len(rows)) if rows[i][0] == 2 and mask[i]]


def straight_lines_until_violation(env, info):
    """Each net: one mark_obstacles line between two of its pads, until KiCad's DRC flags
    one (on the first D2 test board: net 3 crosses net 1)."""
    for net in range(len(info["net_names"])):
        if not info["action_mask"]["net"][net]:
            continue
        obs, *_, info = env.step({"type": 1, "net": net, "candidate": 0, "mode": 0})
        obs, *_, info = env.step({"type": 3, "net": net, "candidate": pad_candidates(obs, info)[0],
                                  "mode": 0})
        targets = pad_candidates(obs, info)
        if targets:
            obs, *_, info = env.step({"type": 4, "net": net, "candidate": targets[0], "mode": 1})
        if obs["drc"]["count"]:
            return obs
        env.step({"type": 2, "net": net, "candidate": 0, "mode": 0})
    raise AssertionError("no violation made")


def test_bare_board_shows_pads_per_layer_and_ratsnest_gone_once_routed(make_env):
    env = make_env("d2", render_mode="rgb_array")
    obs, info = env.reset(options={"index": 0})
    bare = env.render()
    assert bare.shape == (RENDER_SIZE[1], RENDER_SIZE[0], 3) and bare.dtype == np.uint8
    assert count(bare, drawing.LAYER_COLOURS["F.Cu"]) > 100  # pads on both layers
    assert count(bare, drawing.LAYER_COLOURS["B.Cu"]) > 100
    assert count(bare, drawing.RATSNEST) > 200  # every connection is open
    assert count(bare, drawing.HEAD) == 0 and count(bare, drawing.MARKER) == 0
    agent = ScriptedAgent(seed=0)
    terminated = False
    for _ in range(200):
        action = agent.act(obs, info)
        if action is None:
            break
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert terminated, "the scripted agent routes the first D2 test board"
    routed = env.render()
    assert count(routed, drawing.RATSNEST) == 0
    for layer in ("F.Cu", "B.Cu"):  # tracks added copper on both layers
        colour = drawing.LAYER_COLOURS[layer]
        assert count(routed, colour) > count(bare, colour)


def test_head_marker_and_drc_marker(make_env):
    env = make_env("d2", render_mode="rgb_array")
    obs, info = env.reset(options={"index": 0})
    obs, *_, info = env.step({"type": 1, "net": 1, "candidate": 0, "mode": 0})
    assert count(env.render(), drawing.HEAD) == 0  # a net, no head yet
    env.step({"type": 3, "net": 1, "candidate": pad_candidates(obs, info)[0], "mode": 0})
    assert count(env.render(), drawing.HEAD) > 20
    env.step({"type": 2, "net": 1, "candidate": 0, "mode": 0})
    assert count(env.render(), drawing.MARKER) == 0
    obs, info = env.reset(options={"index": 0})
    obs = straight_lines_until_violation(env, info)
    image = env.render()
    assert count(image, drawing.MARKER) > 20
    # the marker is drawn where the observation puts the violation
    ys, xs = np.nonzero(np.all(image == drawing.MARKER, axis=-1))
    assert xs.max() - xs.min() <= 20 and ys.max() - ys.min() <= 20


def test_same_state_same_bytes_and_other_boards_differ(make_env):
    first, second = make_env("d2", render_mode="rgb_array"), make_env("d2", render_mode="rgb_array")
    pictures = []
    for env in (first, second):
        env.reset(options={"index": 1})
        env.step({"type": 1, "net": 0, "candidate": 0, "mode": 0})
        pictures.append(env.render())
    assert pictures[0].tobytes() == pictures[1].tobytes()
    first.reset(options={"index": 2})
    assert first.render().tobytes() != pictures[0].tobytes()


def test_render_modes_none_human_and_before_reset(make_env):
    env = make_env("d2")
    env.reset(options={"index": 0})
    assert env.render() is None
    assert env.unwrapped.metadata["render_modes"] == ["rgb_array"]
    with pytest.raises(EnvValueError, match="allowed: rgb_array"):
        make_env("d2", render_mode="human")
    with pytest.raises(EnvValueError, match="call reset"):
        make_env("d2", render_mode="rgb_array").unwrapped.render()


def test_check_env_with_rgb_array(make_env):
    env = make_env("d1-g10", render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)
    env.reset(seed=0)
    assert env.render().shape == (RENDER_SIZE[1], RENDER_SIZE[0], 3)


def test_drawing_is_pure_and_fits_the_size():
    records = {"layers": ["F.Cu", "In1.Cu", "B.Cu"],
               "outline": [[(0, 0), (20_000_000, 0), (20_000_000, 10_000_000), (0, 10_000_000)]],
               "tracks": [{"layer": "In1.Cu", "start": (1_000_000, 5_000_000),
                           "end": (19_000_000, 5_000_000), "width": 500_000},
                          {"layer": "B.Cu", "start": (2_000_000, 2_000_000),
                           "end": (8_000_000, 2_000_000), "mid": (5_000_000, 1_000_000),
                           "width": 250_000}],
               "vias": [{"x": 10_000_000, "y": 5_000_000, "diameter": 600_000, "drill": 300_000}],
               "ratsnest": [(1_000_000, 1_000_000, 19_000_000, 9_000_000)],
               "markers": [(15_000_000, 8_000_000)], "head": (1_000_000, 5_000_000, "In1.Cu")}
    image = drawing.draw_board(records, (300, 100))
    assert image.shape == (100, 300, 3)
    assert count(image, drawing.layer_colour("In1.Cu")) > 0
    assert count(image, drawing.LAYER_COLOURS["B.Cu"]) > 0
    for colour in (drawing.VIA, drawing.HOLE, drawing.RATSNEST, drawing.MARKER, drawing.HEAD):
        assert count(image, colour) > 0
    assert drawing.png_bytes(image) == drawing.png_bytes(drawing.draw_board(records, (300, 100)))
    # a 2:1 board in a 300 x 100 picture: the height limits the scale, the sides stay background
    assert count(image[:, :40], drawing.BACKGROUND) == 40 * 100


def test_pillow_is_imported_only_by_the_drawing_module():
    from tests.conftest import REPO_ROOT

    importers = sorted(str(p.relative_to(REPO_ROOT)) for p in (REPO_ROOT / "pcbdata").rglob("*.py")
                       if any(line.startswith(("import PIL", "from PIL"))
                              for line in p.read_text(encoding="utf-8").splitlines()))
    assert importers == ["pcbdata/core/drawing.py"]

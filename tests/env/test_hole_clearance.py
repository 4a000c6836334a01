"""KiCad's DRC holds copper of other nets the board's hole clearance from every hole
(`hole_clearance`), a rule of its own beside the copper clearance. A mounting hole (an NPTH
pad: no copper round its hole) is kept only that far from, so the router has to know the hole:
without it, the negotiated agent's tracks on d2r-b `test/board_00088` and `test/board_00116`
ran 0.15-0.245 mm from a 3.2 mm mounting hole under a hole clearance of 0.25 mm, and those two
boards had no clean reference routing in 5 rollouts. Here: the holes the geometry gets, the
router's distance from one, and those two boards routed by the agent and judged by KiCad."""
from __future__ import annotations

from pathlib import Path

import pytest

from pcbdata.env.geometry_bridge import board_geometry
from pcbdata.env.types import NetRules, PadInfo, StaticBoard
from pcbdata.router.walkaround import WalkaroundRouter

MM = 1_000_000
HOLE_CLEARANCE = 250_000
LAYERS = ("F.Cu", "B.Cu")
GEOMETRY_VIOLATIONS = {"clearance", "shorting_items", "tracks_crossing", "hole_clearance",
                       "hole_to_hole"}


def _square(x: int, y: int, half: int) -> list:
    return [[(x - half, y - half), (x + half, y - half), (x + half, y + half),
             (x - half, y + half)]]


def _static(pads) -> StaticBoard:
    outline = (((0, 0), (40 * MM, 0), (40 * MM, 40 * MM), (0, 40 * MM)),)
    nets = (NetRules("A", 150_000, 250_000, 800_000, 400_000),)
    return StaticBoard("b", LAYERS, outline, nets, tuple(pads), (), (), 2, 500_000, None, None,
                       hole_clearance=HOLE_CLEARANCE)


def _pad(net: str, x: int, size: int, drill: int) -> PadInfo:
    return PadInfo(net, x, 20 * MM, (size, size), "circle", (0, 1), drill, f"P{x}",
                   {layer: _square(x, 20 * MM, size // 2) for layer in LAYERS})


def test_a_mounting_hole_is_a_hole_item_and_a_wide_ring_covers_its_own():
    mounting = _pad("", 10 * MM, 3_200_000, 3_200_000)  # NPTH: the pad is the bare hole
    plated = _pad("A", 30 * MM, 1_800_000, 1_000_000)  # ring 0.4 mm + 0.15 mm >= 0.25 mm
    thin = _pad("A", 20 * MM, 1_100_000, 1_000_000)  # ring 0.05 mm + 0.15 mm < 0.25 mm
    holes = [i for i in board_geometry(_static([mounting, plated, thin]), []).copper
             if i.kind == "hole"]
    assert [(h.net, h.start, h.width, h.clearance, h.layers) for h in holes] == [
        ("", (10 * MM, 20 * MM), 3_200_000, HOLE_CLEARANCE, LAYERS),
        ("A", (20 * MM, 20 * MM), 1_000_000, HOLE_CLEARANCE, LAYERS)]
    bare = StaticBoard("b", LAYERS, _static([]).outline, (), (mounting,), (), (), 1, 500_000,
                       None, None)  # a board whose setup has no hole clearance
    assert not [i for i in board_geometry(bare, []).copper if i.kind == "hole"]


def test_the_router_keeps_a_track_the_hole_clearance_from_a_mounting_hole():
    router = WalkaroundRouter(board_geometry(_static([_pad("", 10 * MM, 3_200_000,
                                                           3_200_000)]), []))
    width, clearance = 250_000, 150_000
    edge = 10 * MM + 1_600_000 + width // 2  # the track's edge on the hole's edge, plus gap:

    def clear(gap: int) -> bool:
        x = edge + gap
        return router.segment_is_clear("A", "F.Cu", (x, 5 * MM), (x, 35 * MM), width,
                                       clearance)

    assert not clear(clearance)  # the copper clearance is not enough near a hole
    assert not clear(HOLE_CLEARANCE - 1_000)
    assert clear(HOLE_CLEARANCE)


@pytest.fixture(scope="module")
def mounting_hole_boards(tmp_path_factory) -> Path:
    """The first 117 d2r-b test boards as the build writes them (88 and 116 each have four
    mounting holes)."""
    from pcbdata.testing.sets import write_set

    return write_set(tmp_path_factory.mktemp("holes"), "d2r-b", "test", 117)


@pytest.mark.parametrize("board_id", ["board_00088", "board_00116"])
def test_the_negotiated_agent_keeps_the_hole_clearance_on_d2r_boards(make_env,
                                                                     mounting_hole_boards,
                                                                     board_id):
    from pcbdata.agents.negotiated import NegotiatedAgent
    from pcbdata.runners.rollout import run_episode

    env = make_env("d2r-b", root=str(mounting_hole_boards), split="test", drc="terminal")
    result = run_episode(env, NegotiatedAgent(seed=0), board_id, 0)
    core = env.unwrapped
    assert core.static.hole_clearance == HOLE_CLEARANCE
    holes = [i for i in core._get_router().board.copper if i.kind == "hole"]
    assert len(holes) == 4 and all(h.net == "" and h.clearance == HOLE_CLEARANCE
                                   for h in holes)
    found = {v["type"] for v in core._violations} & GEOMETRY_VIOLATIONS
    assert not found, sorted(found)
    assert result["unconnected"] == 0 and result["drv"] == 0

"""Two real boards the scripted-shove agent used to leave one connection short of, built alone
from the PCBench snapshot, each now routed completely with a clean final DRC:

- `MySRaspiGW_PA_LNA` (D3-A): a pad in a 1.27 mm row of surface pads whose connection needs
  the other side. No via fits on the pad, so the agent drops one a ring step beside it (or
  after a ring step's walk: `ScriptedAgent`'s escape).
- `ATtiny461Breakout` (D3-B): GND and VCC cross between the two rows of a SOIC-20 with every
  pad on the top side; vias beside pads and push_n_shove's re-joins through vias take them
  across (the re-join under a new path, a via near each end, is tested in KiCad in
  `test_shove_env.py`).
"""
from __future__ import annotations

from pathlib import Path

import pytest

from pcbdata.env.types import MAKE_VIA
from tests.conftest import build_from_snapshot

VIA_BESIDE_A_PAD = "MySRaspiGW_MySRaspiGW_PA_LNA"
CROSSING_POWER = "ATtiny461Breakout_ATTiny461DevBoard"


@pytest.fixture(scope="module")
def real_boards(tmp_path_factory, kicad_pool) -> Path:
    root, summary = build_from_snapshot(tmp_path_factory.mktemp("real-routes"),
                                        [VIA_BESIDE_A_PAD, CROSSING_POWER], kicad_pool,
                                        "these boards")
    # Tiers come from size quantiles of the boards built, so alone both are D3-A.
    assert summary["tiers"]["d3-a"]["test"] == 2
    return root


def _episode(root: Path, name: str) -> tuple[dict, list[tuple[dict, dict]]]:
    """One scripted-shove episode (seed 0, DRC at the end) on the board: the final info and
    each action with its router report."""
    import pcbdata.env
    from pcbdata.agents.scripted import ShovingScriptedAgent

    env = pcbdata.env.make(root, "d3-a", split="test", drc="terminal")
    board_id = next(p.name for p in (root / "d3-a" / "test").iterdir() if p.name.endswith(name))
    agent, steps = ShovingScriptedAgent(seed=0), []
    try:
        obs, info = env.reset(seed=0, options={"board_id": board_id})
        ended = False
        while not ended:
            act = agent.act(obs, info)
            if agent.done:
                obs, _, _, _, info = env.unwrapped.finish_episode()
                break
            obs, _, terminated, truncated, info = env.step(act)
            steps.append((act, info.get("router") or {}))
            ended = terminated or truncated
    finally:
        env.close()
    return info, steps


def test_a_via_beside_a_fine_pitch_pad_completes_a_real_board(real_boards):
    info, steps = _episode(real_boards, VIA_BESIDE_A_PAD)
    assert (info["unconnected"], info["drv"]) == (0, 0)
    ring_vias = [r for a, r in steps if a["type"] == MAKE_VIA and a["candidate"] < 8 and r["ok"]]
    assert ring_vias, "the board was completed without a via beside a pad"


def test_a_soic_with_crossing_power_nets_is_completed(real_boards):
    info, steps = _episode(real_boards, CROSSING_POWER)
    assert (info["unconnected"], info["drv"]) == (0, 0)

"""A pad's own clearance override (`(clearance ...)` on the pad or its footprint) is a rule
KiCad's DRC holds other nets' tracks to, instead of the net class clearance. The router took
every pad at its net's clearance, so on D3-C `0596_PoEPi-hardware__autosave-pizero-poe` (a
transistor's pads at 0.2 mm, its nets at 0.15 mm) scripted-shove left 4 `clearance`
violations. Here: D2 boards whose NET1 pads are given a large override."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from pcbdata.agents.scripted import ScriptedAgent
from pcbdata.runners.rollout import run_episode

OVERRIDE_MM = 2.0
BOARDS = 4
GEOMETRY_VIOLATIONS = {"clearance", "shorting_items", "tracks_crossing", "hole_clearance"}


def _with_pad_clearance(text: str, net: str, mm: float) -> str:
    """The board text with `(clearance mm)` on every pad of `net` (a pad's net, three tabs in;
    the board's net list is one tab in)."""
    return re.sub(r'(\n\t\t\t\(net \d+ "' + re.escape(net) + r'"\))',
                  lambda m: f"{m.group(1)}\n\t\t\t(clearance {mm})", text)


@pytest.fixture(scope="module")
def override_set(tmp_path_factory) -> Path:
    from pcbdata.testing.sets import seal_set, write_set

    root = tmp_path_factory.mktemp("pad-clearance")
    write_set(root, "d2", "test", BOARDS)
    for board in sorted((root / "d2" / "test").glob("*/board.kicad_pcb")):
        text = board.read_text(encoding="utf-8")
        patched = _with_pad_clearance(text, "NET1", OVERRIDE_MM)
        assert patched.count("(clearance ") > text.count("(clearance ")
        board.write_text(patched, encoding="utf-8")
    return seal_set(root)


def test_the_router_holds_tracks_to_a_pads_own_clearance(make_env, override_set):
    env = make_env(root=str(override_set), drc="terminal")
    override = round(OVERRIDE_MM * 1e6)
    found = set()
    for index in range(BOARDS):
        board_id = f"board_{index:05d}"
        run_episode(env, ScriptedAgent(seed=0), board_id, 0)
        core = env.unwrapped
        pads = [i for i in core._get_router().board.copper if i.kind == "pad"]
        assert {i.clearance for i in pads if i.net == "NET1"} == {override}
        assert all(i.clearance < override for i in pads if i.net != "NET1")
        core._final_drc()
        found |= {v["type"] for v in core._violations} & GEOMETRY_VIOLATIONS
    assert not found, sorted(found)

"""The three freeroute defects that pcbdata's Specctra round trip works around:
vias modelled as track-sized squares, crossing 45-degree segments of the `grid` engine, and
tracks on the board edge. Each integration test routes a real board that failed before."""
from __future__ import annotations

import json
import shutil

import pytest

from pcbdata.baselines.specctra import FREEROUTE_VARIANTS, freeroute_available
from pcbdata.cli import main
from pcbdata.kicad.specctra_text import (
    net_widths,
    prepare_dsn_for_freeroute,
    restore_ses_after_freeroute,
    shrink_boundary,
    via_diameters,
    widen_wires_for_vias,
)
from pcbdata.testing.sets import seal_set

DSN = """(pcb x
  (resolution um 10)
  (unit um)
  (structure
    (layer F.Cu (type signal))
    (boundary
      (path pcb 0  100000 -80000  0 -80000  0 0  100000 0  100000 -80000)
    )
    (via "Via[0-1]_1200:600_um")
    (rule
      (width 300)
      (clearance 300)
    )
  )
  (library
    (padstack "Via[0-1]_1200:600_um"
      (shape (circle F.Cu 1200))
      (shape (circle B.Cu 1200))
    )
  )
  (network
    (net A (pins P1-1 P2-1))
    (net "B C" (pins P3-1 P4-1))
    (class kicad_default A "B C"
      (circuit (use_via "Via[0-1]_1200:600_um"))
      (rule (width 250) (clearance 300))
    )
  )
)
"""
SES = """(session x
  (routes (resolution um 10)
    (network_out
      (net A (wire (path F.Cu 1200 0 0 100 0)) (via "Via[0-1]_1200:600_um" 100 0))
      (net "B C" (wire (path B.Cu 1200 0 10 100 10)))
    )
  )
)"""


def test_wires_are_planned_as_wide_as_the_largest_via_and_restored():
    assert via_diameters(DSN) == [1200.0, 1200.0]
    assert net_widths(DSN) == (300.0, {"A": 250.0, "B C": 250.0})
    widened, planning = widen_wires_for_vias(DSN)
    assert planning == 1200.0
    assert widened.count("(width 1200)") == 2 and "(width 300)" not in widened
    _, state = prepare_dsn_for_freeroute(DSN)
    restored = restore_ses_after_freeroute(SES, state)
    assert "(path F.Cu 250 0 0 100 0)" in restored and "(path B.Cu 250 0 10 100 10)" in restored
    assert '(via "Via[0-1]_1200:600_um" 100 0)' in restored  # vias keep their padstack
    assert widen_wires_for_vias(DSN.replace("(via ", "(novia ").replace("use_via", "x"))[1] is None


def test_routing_boundary_is_inset_by_via_radius_plus_clearance():
    dsn, _ = prepare_dsn_for_freeroute(DSN)
    assert "(path pcb 0  99100 -79100  900 -79100  900 -900  99100 -900  99100 -79100)" in dsn
    assert shrink_boundary(DSN, 0) == DSN
    assert shrink_boundary(DSN, 60000) == DSN  # would vanish: left alone


def test_no_rollout_uses_the_grid_engine():
    assert all("grid" not in variant for variant in FREEROUTE_VARIANTS)


def _one_board_set(tmp_path, level: str, board_id: str, count: int):
    built = tmp_path / f"built-{level}"
    args = ["build", "d2", "--splits", "test", "--count", str(count), "--no-check",
            "--out", str(built)]
    if level != "default":
        args += ["--level", level]
    assert main(args) == 0
    config = "d2" if level == "default" else f"d2-{level}"
    root = tmp_path / f"set-{level}"
    shutil.copytree(built / config / "test" / board_id, root / config / "test" / board_id)
    return seal_set(root), config


def _route_and_score(root, config, tmp_path, rollouts: int) -> list[dict]:
    runs, report = tmp_path / f"runs-{config}", tmp_path / f"rep-{config}"
    assert main(["route", str(root), "--config", config, "--out", str(runs),
                 "--rollouts", str(rollouts), "--workers", "2"]) == 0
    assert main(["eval", str(root), "--config", config, "--runs", str(runs), "--k",
                 str(rollouts), "--out", str(report), "--workers", "2"]) == 0
    lines = (report / "per_rollout.csv").read_text().splitlines()
    header = lines[0].split(",")
    rows = []
    for line in lines[1:]:
        values = line.split(",")
        rows.append(dict(zip(header, values)))
    return rows


@pytest.mark.skipif(not freeroute_available(), reason="freeroute is not installed")
def test_default_level_boards_route_clean_with_vias_and_any_rollout(tmp_path):
    # Board 1 drew via-to-track shorts and hole clearance errors on rollout 0 before the via
    # fix; board 4's rollout 3 was the `grid` engine's crossing tracks.
    for board_id in ("board_00001", "board_00004"):
        root, config = _one_board_set(tmp_path / board_id, "default", board_id, 5)
        rows = _route_and_score(root, config, tmp_path / board_id, rollouts=4)
        for row in rows:
            assert (row["status"], row["cp"], row["drv"]) == ("ok", "1", "0"), (board_id, row)


@pytest.mark.skipif(not freeroute_available(), reason="freeroute is not installed")
def test_small_expert_board_keeps_tracks_off_the_edge(tmp_path):
    # Before the boundary fix, rollout 0 of this board drew 12 copper_edge_clearance errors.
    root, config = _one_board_set(tmp_path, "expert", "board_00004", 5)
    (row,) = _route_and_score(root, config, tmp_path, rollouts=1)
    assert (row["status"], row["cp"], row["drv"]) == ("ok", "1", "0"), row
    meta = json.loads((tmp_path / "runs-d2-expert" / "board_00004" / "0.json").read_text())
    assert meta["router_version"] != "unknown" and meta["router_cpu_s"] is not None

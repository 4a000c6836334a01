"""`pcbdata route`: the Specctra round trip, freeroute's work-arounds, pluggable commands."""
from __future__ import annotations

import json
import shlex
import sys

import pytest
from boards import base_board, pad, write_instance

from pcbdata.baselines.specctra import freeroute_available
from pcbdata.cli import main
from pcbdata.kicad.specctra import fix_ses_resolution, strip_ses_placement
from pcbdata.kicad.specctra_text import flip_back_components, restore_back_placements
from pcbdata.testing.sets import seal_set

DSN = """(pcb x
  (resolution um 10)
  (unit um)
  (placement
    (component Pad
      (place P1 10000.000000 -10000.000000 front 0.000000 (PN A))
      (place P2 50000.000000 -10000.000000 back 180.000000 (PN A))
    )
  )
  (library
    (image Pad
      (pin Rect[T]Pad_2400_um 1 500 0)
    )
    (padstack Rect[T]Pad_2400_um
      (shape (polygon F.Cu 0  -1200 1200  1300 1200  1300 -1200  -1200 -1200))
      (attach off)
    )
  )
)
"""


def test_fix_ses_resolution_only_when_coordinates_are_in_dsn_units():
    ses = (b"(session x (placement (resolution um 10) "
           b"(component Pad (place P1 10000 -10000 front 0))))")
    assert b"(resolution um 1)" in fix_ses_resolution(DSN.encode(), ses)
    scaled = ses.replace(b"10000 -10000", b"100000 -100000")  # a correct SES: left alone
    assert fix_ses_resolution(DSN.encode(), scaled) == scaled


def test_ses_placement_is_dropped_before_import():
    ses = ('(session x (base_design y)\n  (placement (resolution um 10)\n    (component "A (1)"\n'
           '      (place P1 1 2 front 0)))\n  (routes (network_out (net A))))')
    assert strip_ses_placement(ses) == ("(session x (base_design y)\n  \n"
                                        "  (routes (network_out (net A))))")
    assert strip_ses_placement("(session x (routes))") == "(session x (routes))"


def test_flip_back_components_round_trip():
    dsn, refs = flip_back_components(DSN)
    assert refs == {"P2"}
    assert "(component Pad__back\n      (place P2 50000.000000 -10000.000000 front 180" in dsn
    assert "(place P1 10000.000000 -10000.000000 front 0" in dsn
    assert "(image Pad__back\n      (pin Rect[T]Pad_2400_um__back 1 -500 0)" in dsn
    assert "(polygon B.Cu 0 1200 1200 -1300 1200 -1300 -1200 1200 -1200)" in dsn
    ses = "(component Pad__back\n (place P2 50000 -10000 front 180)\n (place P1 1 2 front 0))"
    assert restore_back_placements(ses, refs) == (
        "(component Pad\n (place P2 50000 -10000 back 180)\n (place P1 1 2 front 0))")


@pytest.fixture()
def small_set(tmp_path):
    root = tmp_path / "set"
    # one pad off the 1 um grid: a router echoing placements rounded to 1 um must not move it;
    # one pad on the back: freeroute must route to it on B.Cu
    board = base_board(pads=[pad(10.1234567, 10, "A"), pad(50, 10, "A", layer="B.Cu"),
                             pad(10, 30, "B"), pad(50, 30, "B")])
    write_instance(board, root / "d2" / "test" / "b0")
    return seal_set(root)


@pytest.mark.skipif(not freeroute_available(), reason="freeroute is not installed")
def test_route_with_freeroute_then_score(small_set, tmp_path, capsys):
    runs = tmp_path / "runs"
    assert main(["route", str(small_set), "--config", "d2", "--out", str(runs),
                 "--workers", "1"]) == 0
    meta = json.loads((runs / "b0" / "0.json").read_text())
    assert meta["status"] == "routed", meta["reason"]
    assert meta["time_s"] > 0 and meta["router"].startswith("freeroute")
    assert main(["eval", str(small_set), "--config", "d2", "--runs", str(runs),
                 "--out", str(tmp_path / "rep"), "--workers", "1"]) == 0
    rows = (tmp_path / "rep" / "per_rollout.csv").read_text().splitlines()
    assert ",ok," in rows[1]  # loads, and nothing moved (integrity)
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert summary["rout"] == 1.0 and summary["time"] == pytest.approx(meta["time_s"])
    # re-running skips what is routed
    assert main(["route", str(small_set), "--config", "d2", "--out", str(runs)]) == 0
    assert "skipped 1" in capsys.readouterr().out


def test_router_cmd_failure_is_recorded(small_set, tmp_path):
    runs = tmp_path / "runs"
    cmd = f"{shlex.quote(sys.executable)} -c 'import sys; sys.exit(3)' {{dsn}} {{ses}}"
    assert main(["route", str(small_set), "--config", "d2", "--out", str(runs),
                 "--router-cmd", cmd, "--workers", "1"]) == 0
    meta = json.loads((runs / "b0" / "0.json").read_text())
    assert meta["status"] == "failed" and "exit 3" in meta["reason"]
    assert not (runs / "b0" / "0.kicad_pcb").exists()
    # what results.json reads: the router as the agent, its budget, the machine
    assert meta["agent_identity"]["name"] == "router-cmd" and meta["seed"] is None
    assert meta["budgets"]["time_limit_s"] == 120.0 and meta["machine"]["cores"] >= 1


def test_router_cmd_needs_placeholders(small_set, tmp_path, capsys):
    assert main(["route", str(small_set), "--config", "d2", "--out", str(tmp_path / "r"),
                 "--router-cmd", "true"]) == 2
    assert "{dsn} and {ses}" in capsys.readouterr().err

"""KiCad's DRC lists at most 499 unconnected items: U past that comes from the pad clusters
(SPEC 4: U = open ratsnest edges), in the evaluator and in the environment alike."""
from __future__ import annotations

import pytest

from pcbdata.evaluator.metrics import (
    board_state,
    every_unconnected,
    unconnected_from_clusters,
)
from pcbdata.kicad.drc_report import UNCONNECTED_LIST_CAP

#: A custom D2 level of 505 two-pad nets: 505 missing connections on the bare board.
MANY_NETS = {"net_counts": [505], "pads_per_net": {"2": 1.0}, "width_mm": [250.0, 250.0],
             "height_mm": [250.0, 250.0]}
MISSING = 505


def _unconnected(net: str) -> dict:
    return {"type": "unconnected_items", "severity": "error", "section": "unconnected",
            "nets": [net], "no_net_item": False, "positions": []}


def _clearance(net: str) -> dict:
    return {"type": "clearance", "severity": "error", "section": "violations", "nets": [net],
            "no_net_item": False, "positions": []}


def test_a_list_below_the_cap_is_kiCad_s_as_it_is():
    violations = [_unconnected("A"), _clearance("B")]
    measurement = {"violations": violations, "clusters": {"A": 5, "B": 1}}
    assert every_unconnected(measurement) is violations


def test_a_full_list_is_replaced_by_the_clusters_items():
    listed = [_unconnected("A")] * UNCONNECTED_LIST_CAP + [_clearance("B")]
    clusters = {"A": 400, "B": 3, "C": 1}
    measurement = {"violations": listed, "clusters": clusters, "wl_mm": 0.0, "vias": 0,
                   "net_count": 4}
    completed = every_unconnected(measurement)
    assert [v for v in completed if v["section"] != "unconnected"] == [_clearance("B")]
    assert sum(v["section"] == "unconnected" for v in completed) == 399 + 2
    assert completed[1:] == unconnected_from_clusters(clusters)
    state = board_state(measurement, counting="strict")
    assert state["unconnected"] == 401 and state["drv"] == 402
    assert every_unconnected({"violations": listed}) is listed  # no clusters: nothing to add


def test_the_build_check_expects_a_full_list_past_the_cap():
    from pcbdata.build.synthetic import check_problem
    from pcbdata.kicad.drc_report import DrcReport, Violation

    def report(listed: int) -> DrcReport:
        item = Violation("unconnected_items", "Missing connection", "error", "", "unconnected")
        return DrcReport([item] * listed, {})

    assert check_problem(report(UNCONNECTED_LIST_CAP), MISSING) is None
    assert check_problem(report(12), 12) is None
    assert check_problem(report(UNCONNECTED_LIST_CAP - 1), MISSING) == (
        "DRC found no other violations and 498 unconnected items (expected 505, of which "
        "KiCad lists at most 499)")
    assert "(expected 12)" in check_problem(report(11), 12)


@pytest.fixture(scope="module")
def many_nets(tmp_path_factory):
    """(instance folder, set folder, config) of one bare board with 505 missing connections,
    built with the KiCad check (which confirms a full list of 499)."""
    from pcbdata.build import SyntheticOptions, build_level
    from pcbdata.sets.configs import level_config

    root = tmp_path_factory.mktemp("many-nets") / "set"
    options = SyntheticOptions(splits=["test"], count=1, check=True, publish=False, workers=1,
                               log=lambda *_: None)
    build_level(root, "d2", "default", MANY_NETS, options)
    config = level_config("d2", "default", MANY_NETS).name
    return root / config / "test" / "board_00000", root, config


def test_the_evaluator_counts_every_missing_connection(evaluator, many_nets):
    instance = many_nets[0]
    record = evaluator.score(instance, instance / "board.kicad_pcb")
    assert record["status"] == "ok", record.get("reason")
    assert record["unconnected"] == MISSING  # KiCad's report: 499
    assert record["raw"]["bare"]["unconnected"] == MISSING
    assert record["drv"] == MISSING and record["rout"] == 0.0 and record["pot"] == 0.0
    assert record["phi"] == pytest.approx(-MISSING - record["penalty"])


def test_the_environment_counts_them_too(many_nets):
    from pcbdata.env.env import RoutingEnv

    _, root, config = many_nets
    for drc in ("step", "terminal"):
        env = RoutingEnv(config=config, root=str(root), split="test", drc=drc, max_nets=512,
                         max_pads=1024)
        try:
            _, info = env.reset(seed=0)
            assert info["unconnected"] == MISSING, drc
            assert info["max_steps"] == 8 * MISSING
        finally:
            env.close()

"""Scores do not depend on the order in which KiCad's DRC threads report violations:
violations are put in a canonical order in the KiCad layer and the metrics sum exactly, so the
same board gives byte-identical records and reports run to run."""
from __future__ import annotations

import json
import math
import random

import pytest
from d2_boards import write_d2_instance, write_honest_board, write_tangled_board

from pcbdata.evaluator.metrics import board_state, drc_penalty
from pcbdata.evaluator.scorer import MEASURE
from pcbdata.kicad.drc_report import DrcReport
from pcbdata.kicad.scoring import violation_order, violation_records
from pcbdata.testing.sets import seal_set

RUNS = 3


def violation(nets, type_="clearance"):
    return {"type": type_, "severity": "error", "section": "violations", "nets": list(nets)}


def many_nets() -> list[dict]:
    """Violations over 40 nets with counts 1..40 (and pairs): the terms of f have many
    different magnitudes, so adding them in another order changes the last digit."""
    out = []
    for i in range(1, 41):
        out += [violation([f"N{i}"]) for _ in range(i)]
        out.append(violation([f"N{i}", f"N{(i * 7) % 40 + 1}"], "shorting_items"))
    return out


def test_the_penalty_is_exact_whatever_the_order():
    violations = many_nets()
    per_order = set()
    plain = set()
    rng = random.Random(12)
    for _ in range(200):
        rng.shuffle(violations)
        per_order.add(drc_penalty(violations))
        # what an order-dependent sum gives: the reason for the exact sum
        counts: dict[str, int] = {}
        for v in violations:
            for net in v["nets"]:
                counts[net] = counts.get(net, 0) + 1
        plain.add(3 * math.log1p(len(counts) / 2) + sum(math.log1p(x / 2) for x in counts.values()))
    assert len(plain) > 1  # the data does exercise rounding
    assert len(per_order) == 1


def test_board_state_is_identical_for_shuffled_violations():
    violations = many_nets() + [
        {"type": "unconnected_items", "severity": "error", "section": "unconnected",
         "nets": ["N3"]},
        {"type": "track_dangling", "severity": "warning", "section": "violations", "nets": ["N4"]}]
    board = {"violations": violations, "wl_mm": 123.456, "vias": 7, "net_count": 41}
    rng = random.Random(3)
    for counting in ("evaluation", "strict"):
        states = set()
        for _ in range(50):
            rng.shuffle(violations)
            states.add(json.dumps(board_state(board, counting=counting), sort_keys=True))
        assert len(states) == 1


@pytest.fixture(scope="module")
def tangled(tmp_path_factory):
    folder = tmp_path_factory.mktemp("determinism")
    return {"instance": write_d2_instance(folder / "instance"),
            "tangled": write_tangled_board(folder / "tangled.kicad_pcb"),
            "honest": write_honest_board(folder / "honest.kicad_pcb")}


def test_violations_come_in_the_canonical_order(tangled, kicad_pool):
    measured = kicad_pool.call(MEASURE, str(tangled["tangled"]), str(tangled["instance"]))
    violations = measured["violations"]
    assert len({v["type"] for v in violations}) >= 5 and len(violations) >= 20
    assert violations == sorted(violations, key=violation_order)
    # the same report text with its entries shuffled gives the same list
    data = kicad_pool.call("pcbdata.kicad.basics:drc", str(tangled["tangled"]),
                           str(tangled["instance"] / "board.kicad_pro"))
    expected = violation_records(DrcReport.from_dict(data))
    rng = random.Random(5)
    for _ in range(5):
        report = DrcReport.from_dict(data)
        rng.shuffle(report.violations)
        for v in report.violations:
            rng.shuffle(v.items)
        assert violation_records(report) == expected


def test_records_are_byte_identical_in_fresh_workers(tangled):
    from pcbdata.evaluator import Evaluator

    records, measurements = set(), set()
    for _ in range(RUNS):
        with Evaluator(workers=1) as evaluator:  # a new KiCad process each time
            for name in ("tangled", "honest"):
                record = evaluator.score(tangled["instance"], tangled[name])
                record.pop("score_seconds")  # a timing, not a score
                records.add((name, json.dumps(record, sort_keys=True)))
            measured = evaluator.pool.call(MEASURE, str(tangled["tangled"]),
                                           str(tangled["instance"]))
            measurements.add(json.dumps(measured, sort_keys=True))
    assert len(records) == 2 and len(measurements) == 1


def test_reports_are_byte_identical_run_to_run(tangled, tmp_path):
    import shutil

    from pcbdata.evaluator import evaluate_set

    root, runs = tmp_path / "set", tmp_path / "runs" / "method"
    for board_id in ("b0", "b1"):
        shutil.copytree(tangled["instance"], root / "d2" / "test" / board_id)
        for rollout, name in enumerate(("tangled", "honest", "tangled")):
            (runs / board_id).mkdir(parents=True, exist_ok=True)
            shutil.copy(tangled[name], runs / board_id / f"{rollout}.kicad_pcb")
    seal_set(root)
    reports = []
    for run in range(2):
        out = tmp_path / f"report{run}"
        evaluate_set(root, "d2", "test", out, runs=runs, k=3, workers=2, progress=False)
        reports.append({name: (out / name).read_bytes() for name in
                        ("per_rollout.csv", "per_board.csv", "summary.json", "summary.md")})
    assert reports[0] == reports[1]

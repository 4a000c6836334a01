"""`pcbdata eval`'s results.json: valid against the shipped schema, what the rollouts record
(null where they do not), @1 and @k aggregates, and only `machine` differs between two
evaluations of the same runs."""
from __future__ import annotations

import json
import math

import jsonschema
import pytest
from boards import ROUTE_A, ROUTE_B, base_board, routed, write_board, write_instance

from pcbdata.cli import main
from pcbdata.core.tree import REFERENCE_FILE
from pcbdata.evaluator.results import derive, schema
from pcbdata.testing.sets import seal_set

IDENTITY = {"name": "scripted", "version": "0.1.0", "checkpoint_sha256": None, "model": None,
            "base_url": None, "prompt_version": None, "sampling": None}
BUDGETS = {"max_steps": "default", "step_limit": 200, "drc": "step", "time_limit_s": 3600.0}


def sidecar(seed: int, seconds: float, **changes) -> str:
    """A rollout's JSON as `pcbdata rollout` writes it."""
    record = {"agent": "scripted", "agent_identity": IDENTITY, "board_id": "x", "seed": seed,
              "rollout": seed, "env_id": "pcbdata/Route-d2-v2", "env_version": 2,
              "budgets": BUDGETS, "time_s": seconds, "steps": 3,
              "machine": {"cores": 2, "cpu_model": "test", "load": [1.5, 1.0, 0.5]}}
    return json.dumps({**record, **changes})


@pytest.fixture(scope="module")
def board_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("set")
    for board_id in ("b0", "b1"):
        write_instance(base_board(), root / "d2" / "test" / board_id)
    write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), root / "d2" / "test" / "b0" /
                REFERENCE_FILE)
    return seal_set(root)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """b0: rollout 0 half routed, 1 clean; b1: both clean. @1: CP 0.5 at index 0, 1.0 at 1."""
    runs = tmp_path_factory.mktemp("runs") / "sampler"
    half, clean = routed(base_board(), [ROUTE_A]), routed(base_board(), [ROUTE_A, ROUTE_B])
    for board_id, boards in (("b0", (half, clean)), ("b1", (clean, clean))):
        for seed, board in enumerate(boards):
            write_board(board, runs / board_id / f"{seed}.kicad_pcb")
            (runs / board_id / f"{seed}.json").write_text(sidecar(seed, 1.0 + seed))
    return runs


def evaluate(board_set, runs, out, *extra) -> dict:
    argv = ["eval", str(board_set), "--config", "d2", "--out", str(out), "--workers", "2",
            *extra] + (["--runs", str(runs), "--k", "2"] if runs else ["--reference"])
    assert main(argv) == 0
    return json.loads((out / "results.json").read_text())


def test_results_json_is_valid_and_records_the_run(board_set, runs, tmp_path):
    data = evaluate(board_set, runs, tmp_path / "report")
    jsonschema.Draft202012Validator(schema()).validate(data)
    assert data["schema"] == "pcbdata-results-1" and data["method"] == "sampler"
    assert data["kicad_version"].startswith("9.0") and data["evaluator_version"]
    assert data["set"]["config"] == "d2" and data["set"]["verified"]
    assert data["set"]["folder"] == str(board_set.resolve())
    assert data["agent"] == IDENTITY and data["seeds"] == [0, 1]
    assert data["env_id"] == {"id": "pcbdata/Route-d2-v2", "version": 2}
    assert data["budgets"] == {"k": 2, "max_steps": "default", "drc": "step",
                               "time_limit_s": 3600.0}
    assert data["runs"] == str(runs.resolve()) and data["machine"]["cores"]
    b0 = data["boards"][0]
    assert b0["best_rollout"] == "1" and [r["cp"] for r in b0["rollouts"]] == [0, 1]
    assert b0["rollouts"][0]["drv_by_type"] == {"unconnected_items": 1}
    assert [(r["seed"], r["time"], r["load"], r["step_limit"]) for r in b0["rollouts"]] \
        == [(0, 1.0, 1.5, 200), (1, 2.0, 1.5, 200)]
    at_1, at_k = data["aggregates"]["at_1"], data["aggregates"]["at_k"]
    assert at_k["cp"] == {"mean": 1.0, "std": None} and at_k["k"] == 2
    assert at_1["n"] == 2 and at_1["cp"]["mean"] == 0.75
    assert at_1["cp"]["std"] == pytest.approx(math.sqrt(0.125))
    assert data["aggregates"]["time"] == {"n": 4, "mean": 1.5, "median": 1.5,
                                          "p95": pytest.approx(2.0), "max": 2.0}
    assert derive(data)["aggregates"] == data["aggregates"]


def test_two_evaluations_of_the_same_runs_differ_only_in_the_machine(board_set, runs, tmp_path):
    first = evaluate(board_set, runs, tmp_path / "one")
    second = evaluate(board_set, runs, tmp_path / "two", "--no-cache")
    again = evaluate(board_set, runs, tmp_path / "one")  # from the score cache this time
    for data in (second, again):
        assert {k: v for k, v in data.items() if k != "machine"} \
            == {k: v for k, v in first.items() if k != "machine"}
    assert first["machine"].keys() == {"cores", "cpu_model", "load"}


def test_what_older_rollouts_do_not_record_is_null(board_set, tmp_path):
    runs = tmp_path / "old"
    write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), runs / "b0" / "0.kicad_pcb")
    (runs / "b0" / "0.json").write_text(json.dumps(
        {"agent": "scripted", "env_id": "pcbdata/Route-d2-v2", "rollout": 0, "time_s": 2.5}))
    write_board(routed(base_board(), [ROUTE_A, ROUTE_B]), runs / "b1" / "0.kicad_pcb")
    (runs / "b1" / "0.json").write_text(json.dumps({"agent": "scripted", "time_s": 1.5}))
    data = evaluate(board_set, runs, tmp_path / "report")
    jsonschema.Draft202012Validator(schema()).validate(data)
    assert data["agent"] == {**dict.fromkeys(IDENTITY), "name": "scripted"}
    assert data["seeds"] is None and data["env_id"] == {"id": None, "version": None}
    assert data["budgets"] == {"k": 2, "max_steps": None, "drc": None, "time_limit_s": None}
    rollout = data["boards"][0]["rollouts"][0]
    assert (rollout["seed"], rollout["load"], rollout["tokens"], rollout["time"]) \
        == (None, None, None, 2.5)
    assert data["aggregates"]["at_1"]["cp"] == {"mean": 1.0, "std": None}


def test_reference_reports_have_a_results_file(board_set, tmp_path):
    data = evaluate(board_set, None, tmp_path / "report")
    jsonschema.Draft202012Validator(schema()).validate(data)
    assert data["reference"] and data["agent"]["name"] == "reference" and data["runs"] is None
    assert [b["board_id"] for b in data["boards"]] == ["b0"]
    assert data["aggregates"]["at_k"]["cp"]["mean"] == 1.0 and data["budgets"]["k"] == 1

"""The environment's DRC after a step leaves out the checks copper cannot change (adding the
instance's own violations of those types back) and the warnings no counting counts
(`pcbdata.kicad.step_drc`): after every step of real episodes it must equal a whole DRC of the
saved board under the instance's project, without those warnings."""
from __future__ import annotations

import json
from pathlib import Path

from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, RULES_FILE
from pcbdata.evaluator.metrics import STRICT_WARNINGS
from pcbdata.kicad.step_drc import (
    STATIC_TYPES,
    is_uncounted_warning,
    static_violations,
    step_project_text,
)
from tests.helpers import skip_without_snapshot


def whole_drc(board: str, instance: str, folder: str) -> list[dict]:
    """KiCad's whole DRC of a saved board under the instance's own project (worker side)."""
    from pcbdata.kicad.basics import load_board, stage_with_project
    from pcbdata.kicad.board_reading import located_violations

    rules = Path(instance) / RULES_FILE
    staged = stage_with_project(board, str(Path(instance) / PROJECT_FILE),
                                str(rules) if rules.is_file() else None, folder)
    return located_violations(load_board(staged))


def _comparable(violations: list[dict]) -> list[str]:
    """Violations as sorted text; KiCad names the items of an unconnected edge in an order
    that varies from run to run, so those positions are left out."""
    return sorted(json.dumps({**v, "positions": None} if v["section"] == "unconnected" else
                             {**v, "positions": [list(p) for p in v["positions"]]},
                             sort_keys=True) for v in violations)


PROJECT = {"board": {"design_settings": {"rule_severities": {
    "clearance": "error", "silk_overlap": "warning", "solder_mask_bridge": "error",
    "silk_over_copper": "warning", "track_dangling": "warning", "copper_sliver": "warning"}}},
    "net_settings": {"classes": [{"name": "Default", "clearance": 0.2}]}}


def _severities(text: str) -> dict:
    return json.loads(text)["board"]["design_settings"]["rule_severities"]


def test_the_step_project_ignores_static_checks_and_uncounted_warnings():
    changed = step_project_text(json.dumps(PROJECT), STRICT_WARNINGS)
    ignored = {k for k, v in _severities(changed).items() if v == "ignore"}
    assert ignored == set(STATIC_TYPES) | {"silk_over_copper", "copper_sliver"}
    assert _severities(changed)["clearance"] == "error"
    assert _severities(changed)["solder_mask_bridge"] == "error"
    assert _severities(changed)["track_dangling"] == "warning"  # the strict count counts it
    assert json.loads(changed)["net_settings"] == PROJECT["net_settings"]


def test_custom_rules_with_severities_keep_every_warning_check():
    rules = '(version 1)\n(rule "silk" (constraint silk_clearance (min 0.1)) (severity error))'
    changed = step_project_text(json.dumps(PROJECT), STRICT_WARNINGS, rules)
    assert {k for k, v in _severities(changed).items() if v == "ignore"} == set(STATIC_TYPES)


def test_a_project_kicad_does_not_write_gets_the_whole_drc():
    for broken in ("{", "[]", json.dumps({"board": {}}),
                   json.dumps({"board": {"design_settings": {"rule_severities": []}}})):
        assert step_project_text(broken, STRICT_WARNINGS) is None


def test_static_violations_are_those_of_the_static_types():
    kept = {"type": "silk_overlap", "section": "violations"}
    assert static_violations([kept, {"type": "clearance", "section": "violations"}]) == [kept]


def _counted(violations: list[dict]) -> list[dict]:
    return [v for v in violations if not is_uncounted_warning(v, STRICT_WARNINGS)]


def _board_with_static_violations(d3_set: Path, kicad_pool, tmp_path: Path) -> str:
    """The first D3-A test board whose own DRC has violations of a static type and warnings
    no counting counts."""
    instances = sorted((d3_set / "d3-a" / "test").iterdir())
    jobs = [(str(i / BOARD_FILE), str(i), str(tmp_path / f"bare{n}"))
            for n, i in enumerate(instances)]
    for job in jobs:
        Path(job[2]).mkdir()
    outcomes = list(kicad_pool.map(f"{__name__}:whole_drc", jobs))  # all: the pool is shared
    for (_, instance, _), outcome in zip(jobs, outcomes):
        assert outcome.ok, outcome.error
        whole = outcome.value
        if static_violations(whole) and len(_counted(whole)) < len(whole):
            return Path(instance).name
    skip_without_snapshot("no D3-A test board of this set has violations of a static type")


def test_step_drc_equals_a_whole_drc_after_every_step(d3_set, kicad_pool, tmp_path):
    import pcbdata.env
    from pcbdata.agents.scripted import ShovingScriptedAgent

    board_id = _board_with_static_violations(d3_set, kicad_pool, tmp_path)
    instance = d3_set / "d3-a" / "test" / board_id
    env = pcbdata.env.make(d3_set, "d3-a", split="test", drc="step")
    agent, checked, steps = ShovingScriptedAgent(seed=0), 0, 0
    try:
        obs, info = env.reset(seed=0, options={"board_id": board_id})
        while True:
            saved = tmp_path / f"step{steps}"
            saved.mkdir()
            env.unwrapped.save(saved / BOARD_FILE)
            whole = next(iter(kicad_pool.map(f"{__name__}:whole_drc", [
                (str(saved / BOARD_FILE), str(instance), str(saved))])))
            assert whole.ok, whole.error
            assert _comparable(env.unwrapped.violations) == \
                _comparable(_counted(whole.value)), steps
            checked += 1
            action = agent.act(obs, info)
            if agent.done:
                break
            obs, _, terminated, truncated, info = env.step(action)
            steps += 1
            if terminated or truncated:
                break
    finally:
        env.close()
    assert checked >= 3


def edited_with_errors_of_static_types(instance: str, folder: str) -> dict:
    """Worker side: the instance under a copy of its project that makes every static check an
    error (so that every count counts them), edited with a track and a via between two pads
    of one net; its environment DRC after each edit beside a whole DRC of the same board."""
    from pcbdata.kicad import routing_session
    from pcbdata.kicad.basics import load_board, stage_with_project
    from pcbdata.kicad.board_reading import located_violations

    project = json.loads((Path(instance) / PROJECT_FILE).read_text())
    severities = project["board"]["design_settings"].setdefault("rule_severities", {})
    severities.update({kind: "error" for kind in STATIC_TYPES})
    made = Path(folder) / "made"
    made.mkdir()
    (made / PROJECT_FILE).write_text(json.dumps(project))
    opened = routing_session.open_instance(str(Path(instance) / BOARD_FILE),
                                           str(made / PROJECT_FILE), None,
                                           str(Path(folder) / "stage"), sorted(STRICT_WARNINGS))
    pads = opened["static"]["pads"]
    net = next(p["net"] for p in pads if p["net"] and sum(q["net"] == p["net"] for q in pads) > 1)
    a, b = [p for p in pads if p["net"] == net][:2]
    start, end = (a["x"], a["y"]), (b["x"], b["y"])
    middle = ((start[0] + end[0]) // 2, (start[1] + end[1]) // 2)
    edits = [{"kind": "track", "net": net, "layer": opened["static"]["layers"][0],
              "points": [start, end], "width": 200000},
             {"kind": "via", "net": net, "at": middle, "diameter": 600000, "drill": 300000}]
    rows = [(opened["snapshot"]["violations"], None)]
    for n, edit in enumerate(edits):
        mine = routing_session.apply([edit], drc=True)["violations"]
        saved = Path(folder) / f"step{n}"
        saved.mkdir()
        routing_session.save(str(saved / BOARD_FILE))
        staged = stage_with_project(str(saved / BOARD_FILE), str(made / PROJECT_FILE), None,
                                    str(saved))
        rows.append((mine, located_violations(load_board(staged))))
    routing_session.close()
    return {"rows": rows}


def test_counted_violations_of_static_types_are_carried_through_every_edit(d3_set, kicad_pool,
                                                                           tmp_path):
    board_id = _board_with_static_violations(d3_set, kicad_pool, tmp_path)
    instance = d3_set / "d3-a" / "test" / board_id
    outcome = next(iter(kicad_pool.map(f"{__name__}:edited_with_errors_of_static_types",
                                       [(str(instance), str(tmp_path))])))
    assert outcome.ok, outcome.error
    rows = outcome.value["rows"]
    for mine, whole in rows[1:]:
        assert _comparable(mine) == _comparable(_counted(whole))
        carried = [v for v in static_violations(mine) if v["severity"] == "error"]
        assert carried  # the project's static errors are there after the edits

"""KiCad project files (`.kicad_pro`) as plain JSON data: pure, no `pcbnew`.

The D3 project-file compatibility pass (SPEC section 3, step 2) and the revalidation project.
The policy arrives as data (the recipe's `[compat]` and `[keep]` tables as plain dicts), so
this module knows KiCad's file format and nothing of the curation. It edits the project only;
the board file is never touched (`pcbdata.kicad.upgrade` checks that its bytes are identical
before and after).
"""
from __future__ import annotations

import copy
from collections.abc import Iterable

from pcbdata.core.textio import canonical_json


def dumps_project(project: dict) -> str:
    """Canonical project text: sorted keys, 2-space indent (KiCad's own layout), newline."""
    return canonical_json(project, indent=2)


def _classes(project: dict) -> list:
    return project.get("net_settings", {}).get("classes", []) or []


def default_clearance(project: dict) -> float | None:
    """Clearance of the `Default` netclass; None when absent, 0 or not a number."""
    for cls in _classes(project):
        if cls.get("name") == "Default":
            value = cls.get("clearance")
            if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0:
                return float(value)
            return None
    return None


def with_default_clearance(project: dict, clearance: float) -> dict:
    """A copy of `project` whose Default netclass clearance is `clearance` (created if absent)."""
    out = copy.deepcopy(project)
    net_settings = out.setdefault("net_settings", {})
    classes = net_settings.get("classes")
    if not isinstance(classes, list):
        classes = net_settings["classes"] = []
    for cls in classes:
        if cls.get("name") == "Default":
            cls["clearance"] = clearance
            return out
    classes.insert(0, {"name": "Default", "clearance": clearance})
    return out


def patch_project(project: dict, compat: dict, observed_spacing: float | None = None) -> dict:
    """Returns the patched copy of a KiCad 9 project dict.

    `compat` is the recipe's `[compat]` table: `ignore_severities` (rule types set to
    "ignore"), `rules` (name -> value set in `board.design_settings.rules`),
    `min_hole_to_hole_cap` (min_hole_to_hole = min(cap, Default clearance)).
    `observed_spacing` (mm) replaces a missing or zero Default clearance.
    """
    out = copy.deepcopy(project)
    clearance = default_clearance(out)
    if clearance is None:
        if observed_spacing is None:
            raise ValueError("the board stores no usable clearance and none was observed")
        out = with_default_clearance(out, float(observed_spacing))
        clearance = float(observed_spacing)
    settings = out.setdefault("board", {}).setdefault("design_settings", {})
    severities = settings.setdefault("rule_severities", {})
    for rule in compat["ignore_severities"]:
        severities[rule] = "ignore"
    rules = settings.setdefault("rules", {})
    for name, value in compat["rules"].items():
        rules[name] = value
    rules["min_hole_to_hole"] = min(float(compat["min_hole_to_hole_cap"]), clearance)
    return out


def check_project(project: dict, skip_checks: Iterable[str]) -> dict:
    """The project the revalidation DRC runs with: `project` with every check of
    `skip_checks` whose severity there is "warning" or "ignore" set to "ignore".

    Only error-severity violations and unconnected items decide whether a board is kept, so
    skipping warning-only checks (silk, text, library parity, ...) cannot change a verdict;
    it halves the DRC time. A check the project makes an error is always run.
    """
    out = copy.deepcopy(project)
    severities = out.setdefault("board", {}).setdefault("design_settings", {}).setdefault(
        "rule_severities", {})
    for name in skip_checks:
        if severities.get(name, "error") in ("warning", "ignore"):  # absent: run it
            severities[name] = "ignore"
    return out

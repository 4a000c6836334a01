"""KiCad's DRC after a routing step, without the checks whose outcome is known beforehand.

The routing environment runs KiCad's DRC after every step that changes copper. Much of each
run on a real board checks what cannot matter there:

- static checks, which no track or via takes part in: silkscreen against silkscreen and the
  board edge, text sizes, courtyard overlaps, footprint library and schematic parity, the pads'
  own padstacks. Their violations are the instance's, found by one whole DRC when it is loaded
  and added back after every step;
- warnings that no counting counts (`pcbdata.evaluator.metrics.is_counted`), such as
  silkscreen clipped by solder mask: the environment leaves them out of its violations
  altogether, so the reward, observation and info are unchanged.

Both are set to "ignore" in a copy of the instance's project (the only place KiCad 9 reads
severities from), which the board is put under after its first, whole DRC. The environment's
violations then equal a whole DRC of the board without the uncounted warnings, up to the items
KiCad names for an unconnected edge, which vary from run to run anyway
(tests/env/test_step_drc.py compares the two after every step of real episodes).
"""
from __future__ import annotations

import json

#: Violation types (the project file's `rule_severities` keys) that only footprints, pads,
#: silkscreen, text, courtyards and the outline take part in. Kept out on purpose: everything
#: about copper, holes, zones and solder mask (a track in another net's pad opening is a
#: solder_mask_bridge; an untented via opens the mask under silkscreen), and the courtyard
#: checks of plated and unplated holes, which may look at vias.
STATIC_TYPES = frozenset({
    "courtyards_overlap", "malformed_courtyard", "missing_courtyard",
    "silk_overlap", "silk_edge_clearance",
    "text_height", "text_thickness", "text_on_edge_cuts", "mirrored_text_on_front_layer",
    "nonmirrored_text_on_back_layer", "unresolved_variable",
    "lib_footprint_issues", "lib_footprint_mismatch", "footprint", "duplicate_footprints",
    "extra_footprint", "missing_footprint", "net_conflict", "footprint_filters_mismatch",
    "footprint_symbol_mismatch", "footprint_type_mismatch",
    "through_hole_pad_without_hole", "padstack",
})


def step_project_text(project_text: str, counted_warnings: frozenset[str],
                      rules_text: str | None = None) -> str | None:
    """The project with every static check set to "ignore", and every check the project makes
    a warning that is not in `counted_warnings`; None when the project is not the JSON KiCad 9
    writes (the steps then run the whole DRC). Custom rules that set a severity of their own
    keep every warning check on: a rule may make some of its violations errors."""
    try:
        project = json.loads(project_text)
        settings = project["board"]["design_settings"]
    except (ValueError, KeyError, TypeError):
        return None
    if not isinstance(settings, dict):
        return None
    severities = settings.setdefault("rule_severities", {})
    if not isinstance(severities, dict):
        return None
    if rules_text is None or "severity" not in rules_text:
        for kind, severity in list(severities.items()):
            if severity == "warning" and kind not in counted_warnings:
                severities[kind] = "ignore"
    for kind in STATIC_TYPES:
        severities[kind] = "ignore"
    return json.dumps(project, indent=2)


def is_uncounted_warning(violation: dict, counted_warnings: frozenset[str]) -> bool:
    """Whether no counting counts this violation, being a warning of a type outside
    `counted_warnings` (unconnected items always count)."""
    return (violation["severity"] == "warning" and violation["type"] not in counted_warnings
            and violation["section"] != "unconnected")


def static_violations(violations: list[dict]) -> list[dict]:
    """The violations of a whole DRC that a step's DRC leaves out."""
    return [v for v in violations if v["type"] in STATIC_TYPES]

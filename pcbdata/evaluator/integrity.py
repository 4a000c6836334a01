"""Integrity check: a submission may only add or change tracks, arcs and vias.

Compares the fingerprint of the routed board with the instance's (see
`pcbdata.kicad.scoring.fingerprint`): nets, footprints, pads (position, shape, size, drill,
layers, net), zones (outline, layers, net, priority), board outline (Edge.Cuts), drawings on
copper layers, the layer set and the design settings the board file carries (solder mask,
paste, via tenting, thickness); the design rules themselves come from the instance's project. Any difference makes the rollout invalid, with the reason.
"""
from __future__ import annotations

CATEGORIES = ("nets", "footprints", "pads", "zones", "outline", "copper_drawings", "rules")
_LABELS = {"nets": "nets", "footprints": "footprints", "pads": "pads", "zones": "zones",
           "outline": "board outline", "copper_drawings": "drawings on copper layers",
           "rules": "rules (layer stack or board-file design settings)"}


def integrity_problems(bare: dict[str, list[str]], routed: dict[str, list[str]]) -> list[str]:
    """One line per changed category, naming the first difference; empty when intact."""
    problems = []
    for category in CATEGORIES:
        before, after = list(bare.get(category, [])), list(routed.get(category, []))
        if before == after:
            continue
        removed = sorted(set(before) - set(after))
        added = sorted(set(after) - set(before))
        detail = []
        if removed:
            detail.append(f"{len(removed)} missing or changed, e.g. {removed[0].split('|')[0]!r}")
        if added:
            detail.append(f"{len(added)} added or changed, e.g. {added[0].split('|')[0]!r}")
        if not detail:
            detail.append(f"count {len(before)} -> {len(after)}")
        problems.append(f"{_LABELS[category]} changed ({'; '.join(detail)})")
    return problems

"""Integrity check: a submission may only add or change tracks, arcs and vias.

The board KiCad checks is the instance's own board with the submission's copper transplanted
onto it (`pcbdata.kicad.scoring`), so nothing else a submission carries can change its score.
This module reports what else it carries that differs from the instance, by comparing the two
fingerprints (`pcbdata.kicad.scoring.fingerprint`): the board as KiCad writes it without copper
(nets; footprints and pads with every local override; zones with their settings; outline;
drawings; layers, stackup and the setup block), the net classes and the design rules as KiCad
resolved them on loading the board with the instance's project. Any difference makes the
rollout invalid, with a reason that names the first difference of each category.

An entry of a fingerprint is `key|part|part...`; entries of a category form a multiset.
"""
from __future__ import annotations

import re
from collections import Counter

CATEGORIES = ("nets", "netclasses", "rules", "setup", "footprints", "pads", "zones", "outline",
              "drawings")
_LABELS = {"nets": "nets", "netclasses": "net classes",
           "rules": "design rules (as KiCad resolves them from the board file)",
           "setup": "board setup (layers, stackup, setup block)", "footprints": "footprints",
           "pads": "pads", "zones": "zones", "outline": "board outline", "drawings": "drawings"}
_SHOWN = 120  # characters of a part quoted in a reason


def natural(text: str) -> list:
    """Sort key putting P2 before P10."""
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", text)]


def _key(entry: str) -> str:
    return entry.split("|", 1)[0]


def _parts(entry: str) -> Counter:
    return Counter(entry.split("|")[1:])


def _clip(text: str) -> str:
    return text if len(text) <= _SHOWN else text[:_SHOWN] + "..."


def _label(part: str) -> str:
    """What a part is about: `Clearance` of `Clearance=0`, `clearance` of `(clearance 0.1)`."""
    if part.startswith("("):
        return part[1:].split(" ", 1)[0].rstrip(")")
    return part.split("=", 1)[0] if "=" in part else part


def describe_change(before: str, after: str) -> str:
    """What differs between two entries of the same key, the first change first: e.g.
    `Clearance=300000 -> Clearance=0 (and 2 more)`, `with (clearance 0.001)`."""
    gone = sorted((_parts(before) - _parts(after)).elements())
    new = sorted((_parts(after) - _parts(before)).elements())
    changes = []
    for part in gone:
        twin = next((n for n in new if _label(n) == _label(part)), None)
        if twin is not None:
            new.remove(twin)
            changes.append(f"{_clip(part)} -> {_clip(twin)}")
        else:
            changes.append(f"without {_clip(part)}")
    if len(changes) == 1 and changes[0].startswith("without") and len(new) == 1:
        changes = [f"{_clip(gone[0])} -> {_clip(new.pop())}"]  # a value: `name|0` -> `name|1`
    changes += [f"with {_clip(part)}" for part in new]
    if not changes:
        return "reordered"
    more = f" (and {len(changes) - 1} more)" if len(changes) > 1 else ""
    return changes[0] + more


def category_problem(label: str, before: list[str], after: list[str]) -> str | None:
    """One line naming the first change, missing and added entry of a category; None if equal."""
    removed = Counter(before) - Counter(after)
    added = Counter(after) - Counter(before)
    if not removed and not added:
        return None
    old_by_key: dict[str, str] = {}
    for entry in sorted(removed):
        old_by_key.setdefault(_key(entry), entry)
    new_by_key: dict[str, str] = {}
    for entry in sorted(added):
        new_by_key.setdefault(_key(entry), entry)
    changed = sorted(set(old_by_key) & set(new_by_key), key=natural)
    missing = sorted(set(old_by_key) - set(new_by_key), key=natural)
    extra = sorted(set(new_by_key) - set(old_by_key), key=natural)
    detail = []
    if changed:
        key = changed[0]
        detail.append(f"{len(changed)} changed, e.g. {key!r}: "
                      f"{describe_change(old_by_key[key], new_by_key[key])}")
    if missing:
        detail.append(f"{len(missing)} missing, e.g. {missing[0]!r}")
    if extra:
        detail.append(f"{len(extra)} added, e.g. {extra[0]!r}")
    return f"{label} changed ({'; '.join(detail)})"


def integrity_problems(bare: dict[str, list[str]], routed: dict[str, list[str]]) -> list[str]:
    """One line per changed category, naming the first difference; empty when intact."""
    problems = []
    for category in CATEGORIES:
        problem = category_problem(_LABELS[category], list(bare.get(category, [])),
                                   list(routed.get(category, [])))
        if problem:
            problems.append(problem)
    return problems


def rollout_problems(bare: dict, routed: dict) -> list[str]:
    """Every reason why a measured submission is invalid: copper that cannot stand on the
    instance (coordinates beyond KiCad's range, a layer without copper, items KiCad dropped, a
    net it lacks, a via of two sizes, copper off the board outline; `scoring.measure`), then
    fingerprint differences."""
    return list(routed.get("copper_problems", [])) + integrity_problems(
        bare["fingerprint"], routed["fingerprint"])

"""Parses the text report that KiCad 9's `pcbnew.WriteDRCReport` writes into plain data.

The report has three sections (violations, unconnected items, footprint errors); each entry is

    [violation_type]: message
        Rule: rule name; severity          (or "Local override; severity")
        @(x mm, y mm): item description [net name] ...

Excluded markers carry the severity word "excluded".
"""
from __future__ import annotations

import re
from dataclasses import asdict, dataclass, field

_SECTION = re.compile(r"^\*\* Found (\d+) (DRC violations|unconnected pads|Footprint errors) \*\*$")
_HEADER = re.compile(r"^\[([A-Za-z0-9_]+)\]: (.*)$")
_ITEM = re.compile(r"^\s+@\(([-0-9.]+) mm, ([-0-9.]+) mm\): (.*)$")
_NET = re.compile(r"\[([^\]]*)\]")
NO_NET = "<no net>"
#: KiCad 9.0.8's DRC report lists at most this many unconnected items, and its header says
#: the same number (measured on D3-C's largest boards: 499 listed for 1,616 missing
#: connections). A list this long may be cut short.
UNCONNECTED_LIST_CAP = 499


@dataclass
class ReportItem:
    x_mm: float
    y_mm: float
    description: str
    net: str | None  # None: the item names no net (board outline, footprint, ...)


@dataclass
class Violation:
    type: str
    message: str
    severity: str  # error, warning, ignore, excluded
    rule: str
    section: str  # "violations", "unconnected" or "footprint"
    items: list[ReportItem] = field(default_factory=list)

    @property
    def nets(self) -> list[str]:
        return sorted({i.net for i in self.items if i.net and i.net != NO_NET})


@dataclass
class DrcReport:
    violations: list[Violation]
    declared_counts: dict[str, int]

    @property
    def unconnected(self) -> list[Violation]:
        return [v for v in self.violations if v.section == "unconnected"]

    def counts_by_type(self, include_unconnected: bool = True) -> dict[str, int]:
        counts: dict[str, int] = {}
        for v in self.violations:
            if v.severity == "excluded" or (not include_unconnected and v.section == "unconnected"):
                continue
            counts[v.type] = counts.get(v.type, 0) + 1
        return dict(sorted(counts.items()))

    def error_counts(self) -> tuple[dict[str, int], int]:
        """Error-severity violations per type, and unconnected items (excluded markers left
        out): what a board is kept or rejected by when only errors and connectivity count."""
        types: dict[str, int] = {}
        unconnected = 0
        for v in self.violations:
            if v.severity == "excluded":
                continue
            if v.section == "unconnected":
                unconnected += 1
            elif v.severity == "error":
                types[v.type] = types.get(v.type, 0) + 1
        return types, unconnected

    def within(self, max_errors: int, max_unconnected: int | None) -> bool:
        """At most `max_errors` error-severity violations and (unless None) `max_unconnected`
        unconnected items (the D3 revalidation rule; the numbers come from the recipe)."""
        types, unconnected = self.error_counts()
        return sum(types.values()) <= max_errors and (max_unconnected is None
                                                      or unconnected <= max_unconnected)

    def to_dict(self) -> dict:
        return {"violations": [asdict(v) for v in self.violations],
                "declared_counts": self.declared_counts}

    @classmethod
    def from_dict(cls, data: dict) -> DrcReport:
        violations = [
            Violation(**{**v, "items": [ReportItem(**i) for i in v["items"]]})
            for v in data["violations"]
        ]
        return cls(violations=violations, declared_counts=data["declared_counts"])


_SECTION_KEYS = {"DRC violations": "violations", "unconnected pads": "unconnected",
                 "Footprint errors": "footprint"}


def parse_drc_report(text: str) -> DrcReport:
    """Parses the report text; raises ValueError if it is not a KiCad DRC report."""
    if "** Drc report for" not in text:
        raise ValueError("not a KiCad DRC report")
    violations: list[Violation] = []
    declared: dict[str, int] = {}
    section = None
    current: Violation | None = None
    for line in text.splitlines():
        match = _SECTION.match(line)
        if match:
            section = _SECTION_KEYS[match.group(2)]
            declared[section] = int(match.group(1))
            current = None
            continue
        match = _HEADER.match(line)
        if match and section is not None:
            current = Violation(type=match.group(1), message=match.group(2), severity="",
                                rule="", section=section)
            violations.append(current)
            continue
        if current is None:
            continue
        match = _ITEM.match(line)
        if match:
            net_match = _NET.search(match.group(3))
            current.items.append(ReportItem(float(match.group(1)), float(match.group(2)),
                                            match.group(3),
                                            net_match.group(1) if net_match else None))
        elif line.startswith("    ") and not current.severity and ";" in line:
            rule, _, severity = line.strip().rpartition(";")
            current.rule = rule.strip()
            current.severity = severity.strip()
    return DrcReport(violations=violations, declared_counts=declared)

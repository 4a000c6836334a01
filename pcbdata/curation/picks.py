"""Characteristics table, tiers and evaluation picks (SPEC section 3, steps 4-6). Pure data."""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from pcbdata.core.tree import d3_board_id
from pcbdata.sets.configs import D3_TIERS

if TYPE_CHECKING:
    from pcbdata.sets.recipe import Override, Recipe

COLUMNS = ["board_id", "name", "nets", "components", "pads", "layers", "tier", "in_test"]


@dataclass
class Row:
    name: str
    nets: int
    components: int
    pads: int
    layers: int
    row: int = 0
    tier: str = ""
    in_test: bool = False

    @property
    def board_id(self) -> str:
        return d3_board_id(self.row, self.name)


def number_rows(rows: list[Row]) -> list[Row]:
    """Sorts by (pads, nets, components, name) and numbers the rows from 1."""
    ordered = sorted(rows, key=lambda r: (r.pads, r.nets, r.components, r.name))
    for index, row in enumerate(ordered, start=1):
        row.row = index
    return ordered


def assign_tiers(rows: list[Row], a_size: int, b_max_pads: int) -> dict[str, list[Row]]:
    """D3-A = the first `a_size` rows; of the rest, B = pads <= b_max_pads, C = the others."""
    tiers: dict[str, list[Row]] = {"A": [], "B": [], "C": []}
    for index, row in enumerate(rows):
        row.tier = "A" if index < a_size else ("B" if row.pads <= b_max_pads else "C")
        tiers[row.tier].append(row)
    return tiers


def array_split(items: list, parts: int) -> list[list]:
    """numpy.array_split semantics: the first len % parts chunks get one extra item."""
    if parts < 1:
        raise ValueError("parts must be >= 1")
    size, extra = divmod(len(items), parts)
    chunks, start = [], 0
    for index in range(parts):
        end = start + size + (1 if index < extra else 0)
        chunks.append(items[start:end])
        start = end
    return chunks


def picks(rows: list[Row], bins: int, layers: int | None = 2,
          trim_fraction: float = 0.0) -> list[Row]:
    """The evaluation subset of a tier.

    Keeps boards with `layers` copper layers (None: all), sorts by (pads, nets, name), drops
    the largest round(trim_fraction * n) by that order, cuts the rest into `bins` near-equal
    bins (numpy array_split) and takes each non-empty bin's lower median ((len - 1) // 2).
    """
    pool = [r for r in rows if layers is None or r.layers == layers]
    pool.sort(key=lambda r: (r.pads, r.nets, r.name))
    trim = round(trim_fraction * len(pool))
    if trim:
        pool = pool[: len(pool) - trim]
    return [chunk[(len(chunk) - 1) // 2] for chunk in array_split(pool, bins) if chunk]


def apply_replacements(chosen: list[Row], tier_rows: list[Row], config: str,
                       overrides: list[Override]) -> tuple[list[Row], list[dict]]:
    """Applies `replace_pick` overrides of `config`; returns (picks, applied/unapplied notes)."""
    by_name = {r.name: r for r in tier_rows}
    out = list(chosen)
    notes = []
    for o in overrides:
        if o.config != config:
            continue
        names = [r.name for r in out]
        why = ""
        if o.board not in names:
            why = "board is not a computed pick"
        elif o.replacement not in by_name:
            why = "replacement is not in the tier"
        elif o.replacement in names:
            why = "replacement is already a pick"
        else:
            out[names.index(o.board)] = by_name[o.replacement]
        notes.append({**o.as_dict(), "applied": not why, "why": why})
    return out, notes


def published_subset(tier_rows: list[Row], config: str,
                     pinned: tuple[str, ...]) -> tuple[list[Row] | None, dict]:
    """The published test split of `config` (SPEC section 3, step 9) if every pinned board is
    in the tier, else None; and the note saying which (naming the boards missing)."""
    by_name = {r.name: r for r in tier_rows}
    missing = [name for name in pinned if name not in by_name]
    note = {"kind": "published_test", "config": config, "boards": list(pinned),
            "applied": not missing, "missing": missing,
            "why": "" if not missing else
            f"{', '.join(missing)} not kept in the tier: the {config} test split is cut by the "
            f"rule and differs from the published one"}
    return (None if missing else [by_name[name] for name in pinned]), note


def evaluation_subsets(tiers: dict[str, list[Row]], recipe: Recipe,
                       unloadable: frozenset[str] = frozenset(),
                       ) -> tuple[dict[str, list[Row]], list]:
    """Test subsets per tier, in table order: the recipe's published lists where every board of
    one is in its tier, else the rule with the recipe's overrides applied."""
    rule = recipe.picks
    notes: list[dict] = []
    leave_out = {o.board: o for o in recipe.overrides("exclude_from_test")
                 if (o.config or D3_TIERS["A"]) == D3_TIERS["A"]}
    subsets = {"A": [r for r in tiers["A"] if r.name not in leave_out and r.name not in unloadable]}
    for name, o in leave_out.items():
        present = any(r.name == name for r in tiers["A"])
        notes.append({**o.as_dict(), "applied": present,
                      "why": "" if present else "board is not in the tier"})
    for tier, trim in (("B", 0.0), ("C", rule.c_trim_fraction)):
        config = D3_TIERS[tier]
        chosen = None
        if config in recipe.published:
            chosen, note = published_subset(tiers[tier], config, recipe.published[config])
            notes.append(note)
        if chosen is None:
            chosen = picks(tiers[tier], rule.bins, rule.layers, trim)
            chosen, more = apply_replacements(chosen, tiers[tier], config,
                                              recipe.overrides("replace_pick"))
            notes.extend(more)
        # exclude_from_test overrides for B/C configs drop picks too
        drop = {o.board for o in recipe.overrides("exclude_from_test") if o.config == config}
        subsets[tier] = sorted((r for r in chosen if r.name not in drop), key=lambda r: r.row)
    for rows in subsets.values():
        for r in rows:
            r.in_test = True
    return subsets, notes


def exclude_after_picks(rows: list[Row], tiers: dict[str, list[Row]],
                        subsets: dict[str, list[Row]], overrides: list[Override],
                        ) -> tuple[list[Row], list[dict]]:
    """Drops the boards of `exclude_after_picks` overrides from the table, their tier and its
    test subset, after the tiers and picks were cut with them in the pool (SPEC section 3,
    step 8), and numbers the remaining rows again in the same order. Returns (the table, the
    notes)."""
    notes, gone = [], set()
    for o in overrides:
        tier = next((r.tier for r in rows if r.name == o.board), "")
        why = ("board is not kept" if not tier else
               f"board is in {D3_TIERS[tier]}, not {o.config}" if o.config
               and D3_TIERS[tier] != o.config else
               "board is a test pick" if any(r.name == o.board for r in subsets[tier]) else "")
        if not why:
            gone.add(o.board)
        notes.append({**o.as_dict(), "applied": not why, "why": why})
    for key in tiers:
        tiers[key] = [r for r in tiers[key] if r.name not in gone]
    table = [r for r in rows if r.name not in gone]
    for index, row in enumerate(table, start=1):
        row.row = index
    return table, notes

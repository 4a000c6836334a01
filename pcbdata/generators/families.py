"""The table of generator families: one `Family` record per family (`pcbdata.generators.base`).

The built-in families are D1, D2 and D2R (`pcbdata.generators.d1`, `.d2`, `.d2r`, one package
each, exporting `FAMILY`). Everything that depends on a family (config names and the registry
of configs, seed streams, the environment's capacities, the dataset card, `pcbdata levels`)
reads this table, so a new family is one package with its `FAMILY`, one presets file, one CLI
module (`pcbdata/cli/build_<family>.py`, or a caller of `pcbdata.build.build_level`), and one
call:

    register_family(FAMILY)

Names must be unique, not `d3` (the curated set) and must not start another family's config
names (`d2x` is fine beside `d2`: configs are `<family>-<level>`); seed keys must be unique.
"""
from __future__ import annotations

import difflib

from pcbdata.core.errors import UserError
from pcbdata.generators import d1, d2, d2r
from pcbdata.generators.base import Family

#: The curated real-board family: configs, but no generator (`pcbdata.sets.configs`).
CURATED = "d3"

_TABLE: dict[str, Family] = {f.name: f for f in (d1.FAMILY, d2.FAMILY, d2r.FAMILY)}


def register_family(family: Family) -> Family:
    """Adds `family` to the table (again: replaced, for the same name and seed key); a name
    or seed key another family holds is a `UserError`."""
    if family.name == CURATED or not family.name or "-" in family.name:
        raise UserError(f"family name {family.name!r}: not d3, not empty, no '-'")
    for other in _TABLE.values():
        if other.name != family.name and other.seed_key == family.seed_key:
            raise UserError(f"family {family.name!r}: seed key {family.seed_key} is "
                            f"{other.name!r}'s; random streams must be disjoint")
    _TABLE[family.name] = family
    return family


def families() -> list[Family]:
    """Every registered family, in listing order (`rank`, then name)."""
    return sorted(_TABLE.values(), key=lambda f: (f.rank, f.name))


def family(name: str) -> Family:
    """A family by name; an unknown one is a `UserError` naming the closest."""
    if name in _TABLE:
        return _TABLE[name]
    close = difflib.get_close_matches(name, list(_TABLE), n=1, cutoff=0.5)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise UserError(f"unknown board family {name!r}{hint} (families: "
                    f"{', '.join(f.name for f in families())})")


def is_family(name: str) -> bool:
    return name in _TABLE

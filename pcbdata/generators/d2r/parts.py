"""Which parts a realistic (`d2r`) board gets: one footprint drawn from the board's part mix,
or one drawn by pin count (the kind's smallest size with enough pins), for a board that needs
more pins than its parts have."""
from __future__ import annotations

import math
from dataclasses import dataclass

from pcbdata.core.rng import Stream
from pcbdata.generators.d2r import footprints as fp
from pcbdata.generators.d2r.params import D2RParams

# The sizes each kind is drawn from (pins; QFN and QFP: pins per side).
DIP_PINS = (8, 14, 16, 20, 28)
SOIC_PINS = (8, 14, 16)
TSSOP_PINS = (8, 14, 16, 20, 24)
QFN_PINS_PER_SIDE = (4, 5, 6, 8)
QFP_PINS_PER_SIDE = (8, 11, 12, 16)
# Connector families, in the order of the draw: pin counts from, to (both included).
CONNECTOR_PINS = (("jst_ph", 2, 6), ("jst_sh", 2, 8), ("terminal_block", 2, 4))
# A header drawn by pin count may be as large as `header_pins` allows any header (2 x 20).
SIZED_HEADER_MAX_PINS = 40
# The most pins a part of each kind surely has (a QFN's exposed pad is drawn, so not counted).
LARGEST_PINS = {"passive": 2, "axial": 2, "radial": 2, "sot23": 3, "soic": max(SOIC_PINS),
                "tssop": max(TSSOP_PINS), "dip": max(DIP_PINS),
                "qfn": 4 * max(QFN_PINS_PER_SIDE), "qfp": 4 * max(QFP_PINS_PER_SIDE),
                "header": SIZED_HEADER_MAX_PINS,
                "connector": max(high for _, _, high in CONNECTOR_PINS)}


@dataclass(frozen=True)
class Style:
    """One board's leaning: its part mix, passive sizes and how far it leans to SMD parts (0:
    through-hole only, 1: SMD only)."""

    part_mix: dict[str, float]
    passive_sizes: dict[str, float]
    smd_lean: float = 0.5
    #: Pad centre distance (mm) of this board's passives per size, where the board's library
    #: is not the nominal one (`land_pattern_spread`); sizes not listed are nominal.
    passive_pitches: dict[str, float] | None = None


def weighted(stream: Stream, table: dict[str, float]) -> str:
    keys = sorted(table)
    return stream.weighted(keys, [table[k] for k in keys])


def pins(template: fp.Template) -> int:
    """Pins a net can reach: plated pads but the mounting tabs."""
    return sum(1 for pad in template.pads if pad.plated and pad.number != "MP")


def joinable_pins(counts: list[int]) -> int:
    """At most how many of the pins of parts with these pin counts nets can join: a signal net
    joins pins of distinct parts, so the largest part's pins beyond all the others' together
    stay free."""
    total = sum(counts)
    return min(total, 2 * (total - max(counts, default=0)))


def pins_to_ask(counts: list[int], wanted: float) -> int:
    """Pins for one more part, drawn by pin count, on a board whose parts have `counts` pins:
    the fewest with which `wanted` pins can be joined. If no single part reaches that (the
    board's pins could join at most twice their number), half of what is missing: the next
    part, of the other half, then can."""
    total = sum(counts)
    if wanted > 2 * total:
        return math.ceil((wanted - total) / 2)
    return next(n for n in range(1, math.ceil(wanted) + 1)
                if joinable_pins([*counts, n]) >= wanted)


def _smallest_reaching(sizes: tuple[int, ...], wanted: int) -> int:
    """The smallest size of at least `wanted`, else the largest."""
    return next((s for s in sizes if s >= wanted), sizes[-1])


class PartDrawer:
    """Draws one board's footprints from the library, by the level's parameters."""

    def __init__(self, params: D2RParams):
        self.p = params

    def from_mix(self, stream: Stream, style: Style) -> fp.Template:
        """A part of the kind the board's mix draws, at a size drawn for that kind."""
        return self._of_kind(stream, style, weighted(stream, style.part_mix))

    def by_pins(self, stream: Stream, style: Style, wanted: int) -> fp.Template:
        """A part with at least `wanted` pins: its kind drawn by the board's mix among the kinds
        that come that large (if none does, among those that come largest), at the kind's
        smallest size that has them. Real small boards reach their pad count with one large
        connector or IC, not with many two-pin parts."""
        largest = {k: LARGEST_PINS[k] for k, w in style.part_mix.items() if w > 0}
        reach = min(wanted, max(largest.values()))
        kinds = {k: style.part_mix[k] for k, top in largest.items() if top >= reach}
        kind = weighted(stream, kinds)
        if LARGEST_PINS[kind] <= 3:
            return self._of_kind(stream, style, kind)  # one size: nothing to choose
        return self._sized(stream, kind, reach)

    def _of_kind(self, stream: Stream, style: Style, kind: str) -> fp.Template:
        p = self.p
        if p.package_variety and kind in VARIANT_KINDS and stream.random() < p.package_variety:
            return _variant(stream, kind)
        if kind == "passive":
            size = weighted(stream, style.passive_sizes)
            return fp.passive(size, (style.passive_pitches or {}).get(size))
        if kind == "axial":
            return fp.axial(stream.choice(fp.AXIAL_PITCHES))
        if kind == "radial":
            return fp.radial(stream.choice(p.radial_pitches_mm))
        if kind == "sot23":
            return fp.sot23()
        if kind == "header":
            rows = 2 if stream.random() < p.two_row_header_fraction else 1
            low, high = p.header_pins
            count = low + stream.integer(high - low + 1)
            return fp.pin_header(rows, max(1, count // rows))
        if kind == "connector":
            family, low, high = CONNECTOR_PINS[stream.integer(len(CONNECTOR_PINS))]
            return _connector(family, low + stream.integer(high - low + 1))
        sizes = {"dip": DIP_PINS, "soic": SOIC_PINS, "tssop": TSSOP_PINS,
                 "qfn": QFN_PINS_PER_SIDE, "qfp": QFP_PINS_PER_SIDE}[kind]
        return self._ic(stream, kind, stream.choice(sizes))

    def _sized(self, stream: Stream, kind: str, wanted: int) -> fp.Template:
        """The kind's smallest footprint with at least `wanted` pins (its largest if none)."""
        if kind == "header":
            rows = 2 if stream.random() < self.p.two_row_header_fraction else 1
            per_row = -(-wanted // rows)
            return fp.pin_header(rows, min(max(per_row, 2 // rows), SIZED_HEADER_MAX_PINS // rows))
        if kind == "connector":
            reaching = [c for c in CONNECTOR_PINS if c[2] >= wanted] or [
                max(CONNECTOR_PINS, key=lambda c: c[2])]
            family, low, high = reaching[stream.integer(len(reaching))]
            return _connector(family, min(max(wanted, low), high))
        if kind in ("qfn", "qfp"):
            per_side = QFN_PINS_PER_SIDE if kind == "qfn" else QFP_PINS_PER_SIDE
            return self._ic(stream, kind, _smallest_reaching(per_side, -(-wanted // 4)))
        sizes = {"dip": DIP_PINS, "soic": SOIC_PINS, "tssop": TSSOP_PINS}[kind]
        return self._ic(stream, kind, _smallest_reaching(sizes, wanted))

    def _ic(self, stream: Stream, kind: str, size: int) -> fp.Template:
        """An IC package of `size` pins (QFN, QFP: per side), its pitch drawn."""
        p = self.p
        if kind == "dip":
            return fp.dip(size)
        if kind == "soic":
            return fp.soic(size)
        if kind == "tssop":
            return fp.tssop(size)
        if kind == "qfn":
            return fp.qfn(size, stream.choice(p.qfn_pitches_mm),
                          stream.random() < p.exposed_pad_fraction)
        return fp.qfp(size, stream.choice(p.qfp_pitches_mm))


# Kinds that come in other packages (`package_variety`, `_variant`).
VARIANT_KINDS = ("axial", "radial", "sot23", "header", "connector")


def _variant(stream: Stream, kind: str) -> fp.Template:
    """A part of `kind` in another package than the level's own (`package_variety`): another
    lead spacing for an axial part, a capacitor of another pin distance (to 0.01 mm), an LED,
    a crystal or a TO-92 for a radial one, a SOT-23-5/6, SC-70, SOT-89 or SOT-223 for a
    SOT-23, a 2.0 mm header or another connector family for a header or connector
    (`fp.RADIAL_VARIANTS`, `fp.THT_CONNECTORS`). SMD passives keep their kind's land patterns
    (`land_pattern_spread` varies those)."""
    if kind == "axial":
        return fp.axial(stream.choice(fp.AXIAL_VARIANT_PITCHES))
    if kind == "radial":
        name, count, (low, high), size, drill = fp.RADIAL_VARIANTS[
            stream.integer(len(fp.RADIAL_VARIANTS))]
        pitch = low if low == high else round(stream.uniform(low, high), 2)
        return fp.radial_variant(name, count, pitch, size, drill)
    if kind == "sot23":
        return fp.sot_variant(stream.choice(fp.SOT_VARIANTS))
    name, pitch, size, drill, low, high = fp.THT_CONNECTORS[stream.integer(len(fp.THT_CONNECTORS))]
    return fp.tht_connector(name, pitch, size, drill, low + stream.integer(high - low + 1))


def _connector(family: str, count: int) -> fp.Template:
    maker = {"jst_ph": fp.jst_ph, "jst_sh": fp.jst_sh, "terminal_block": fp.terminal_block}
    return maker[family](count)

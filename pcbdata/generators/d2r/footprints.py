"""The parametric footprint library of the realistic family (`d2r`): passives, SOT-23,
SOIC/TSSOP, QFN (optional exposed pad) and QFP, 2.54 mm pin headers, connectors, mounting holes.

Dimensions follow the usual IPC-7351 nominal land patterns (rounded to 10 micrometres); each
template is centred on its origin, and its courtyard encloses every pad with `COURTYARD_MARGIN`.
A template holds no nets: the generator assigns them per placed part.
"""
from __future__ import annotations

from dataclasses import dataclass

from pcbdata.model.board import PadShape, PartPad, mm_to_nm

COURTYARD_MARGIN_MM = 0.25
# Two-pad passives: (pad width along the axis, pad height, pad centre distance), mm. The centre
# distances are the common ones of published land patterns (0603 at 1.5, 0805 at 1.9 mm), the
# pitches real boards' passives show most (docs/realism.md).
PASSIVES = {"0402": (0.54, 0.64, 0.97), "0603": (0.8, 0.95, 1.5),
            "0805": (1.0, 1.45, 1.9), "1206": (1.15, 1.8, 3.0)}
# The pad centre distances other published land patterns of each size give (IPC-7351's
# least and most density levels, hand-soldering variants, vendor and EDA-tool libraries): a
# board drawing its passives' land patterns from another library (`land_pattern_spread`) gets
# one distance per size, uniform in this range (mm).
PASSIVE_PITCH_RANGES_MM = {"0402": (0.9, 1.3), "0603": (1.4, 1.9), "0805": (1.9, 2.5),
                           "1206": (2.7, 3.6)}
# The pad centre distances of published libraries' land patterns of each size (mm): KiCad's
# own over its history (its KiCad 4 `Resistors_SMD` and `Capacitors_SMD` libraries, nominal and
# hand-soldering, every version; its KiCad 5 IPC-7351 nominal ones) and the IPC nominal of
# `PASSIVES`. A board drawing its passives' land patterns from a library
# (`land_pattern_library`) takes one of these per size, as boards made with such libraries do.
PASSIVE_LIBRARY_PITCHES_MM = {"0402": (0.82, 0.9, 0.97, 1.1),
                              "0603": (1.5, 1.524, 1.65, 1.9, 2.2),
                              "0805": (1.7, 1.9, 2.0, 2.5, 2.6, 2.7),
                              "1206": (2.9, 2.925, 3.0, 3.4, 4.0, 4.6)}
# Fine-pitch packages: pitch -> pad width across the pitch (what keeps the gap between pins).
QFN_PAD_WIDTH = {0.4: 0.2, 0.5: 0.25, 0.65: 0.35}
QFP_PAD_WIDTH = {0.4: 0.2, 0.5: 0.28, 0.65: 0.38, 0.8: 0.5}
KINDS = ("passive", "axial", "radial", "sot23", "soic", "tssop", "dip", "qfn", "qfp", "header",
         "connector")
# Through-hole two-pin parts: axial (resistors, diodes) lead spacings; radial ones (capacitors)
# are a parameter of the family (`radial_pitches_mm`), within these bounds (1.6 mm pads).
AXIAL_PITCHES = (7.62, 10.16)
RADIAL_PITCH_RANGE_MM = (2.0, 10.0)


@dataclass(frozen=True)
class Template:
    """A footprint shape: its pads in its own frame, courtyard half sizes (nm), and how many of
    its pads are power/ground pins by nature (an exposed pad is ground)."""

    name: str
    kind: str
    pads: tuple[PartPad, ...]
    courtyard: tuple[int, int]

    @property
    def through_hole(self) -> bool:
        return any(p.drill for p in self.pads)


def _pad(number, x_mm, y_mm, shape: PadShape, w_mm, h_mm, drill_mm=0.0, plated=True) -> PartPad:
    return PartPad(number=str(number), dx=mm_to_nm(x_mm), dy=mm_to_nm(y_mm), shape=shape,
                   width=mm_to_nm(w_mm), height=mm_to_nm(h_mm), drill=mm_to_nm(drill_mm),
                   plated=plated)


def _template(name: str, kind: str, pads: list[PartPad]) -> Template:
    margin = mm_to_nm(COURTYARD_MARGIN_MM)
    half_w = max(abs(p.dx) + p.width // 2 for p in pads) + margin
    half_h = max(abs(p.dy) + p.height // 2 for p in pads) + margin
    # Courtyards on a 10 micrometre grid keep the files short.
    step = 10_000
    return Template(name, kind, tuple(pads),
                    (-(-half_w // step) * step, -(-half_h // step) * step))


def passive(size: str, pitch_mm: float | None = None) -> Template:
    """A two-pad SMD passive of `size`, its pads `pitch_mm` apart (default: the size's
    nominal distance, `PASSIVES`)."""
    w, h, nominal = PASSIVES[size]
    pitch = nominal if pitch_mm is None else pitch_mm
    pads = [_pad(1, -pitch / 2, 0, "roundrect", w, h), _pad(2, pitch / 2, 0, "roundrect", w, h)]
    name = f"RC_{size}" if pitch_mm is None else f"RC_{size}_P{pitch_mm:g}"
    return _template(name, "passive", pads)


def axial(pitch: float) -> Template:
    pads = [_pad(1, -pitch / 2, 0, "rect", 1.6, 1.6, 0.8),
            _pad(2, pitch / 2, 0, "circle", 1.6, 1.6, 0.8)]
    return _template(f"Axial_P{pitch:g}", "axial", pads)


def radial(pitch: float) -> Template:
    pads = [_pad(1, -pitch / 2, 0, "rect", 1.6, 1.6, 0.8),
            _pad(2, pitch / 2, 0, "circle", 1.6, 1.6, 0.8)]
    return _template(f"Radial_P{pitch:g}", "radial", pads)


def dip(n: int) -> Template:
    """A DIP-n: 2.54 mm pitch, rows 7.62 mm apart."""
    pads = []
    for pad in _dual_row(n, 2.54, 3.81, 1.6, 1.6):
        first = pad.number == "1"
        pads.append(PartPad(number=pad.number, dx=pad.dx, dy=pad.dy,
                            shape="rect" if first else "circle", width=pad.width,
                            height=pad.height, drill=mm_to_nm(0.8)))
    return _template(f"DIP-{n}", "dip", pads)


def sot23() -> Template:
    pads = [_pad(1, -1.0, 0.95, "roundrect", 1.0, 0.6), _pad(2, -1.0, -0.95, "roundrect", 1.0, 0.6),
            _pad(3, 1.0, 0.0, "roundrect", 1.0, 0.6)]
    return _template("SOT-23", "sot23", pads)


def _dual_row(n: int, pitch: float, row_x: float, w: float, h: float) -> list[PartPad]:
    """Pins 1..n/2 down the left row, the rest up the right row."""
    per_row = n // 2
    top = (per_row - 1) * pitch / 2
    pads = [_pad(i + 1, -row_x, -top + i * pitch, "roundrect", w, h) for i in range(per_row)]
    pads += [_pad(per_row + i + 1, row_x, top - i * pitch, "roundrect", w, h)
             for i in range(per_row)]
    return pads


def soic(n: int) -> Template:
    return _template(f"SOIC-{n}", "soic", _dual_row(n, 1.27, 2.475, 1.95, 0.6))


def tssop(n: int) -> Template:
    return _template(f"TSSOP-{n}", "tssop", _dual_row(n, 0.65, 2.8875, 1.475, 0.4))


def _quad(per_side: int, pitch: float, reach: float, length: float, width: float) -> list[PartPad]:
    """Pins counter-clockwise from the top of the left side, `reach` from the centre."""
    first = (per_side - 1) * pitch / 2
    pads: list[PartPad] = []
    for side in range(4):
        for i in range(per_side):
            along = -first + i * pitch
            number = side * per_side + i + 1
            if side == 0:
                pads.append(_pad(number, -reach, along, "roundrect", length, width))
            elif side == 1:
                pads.append(_pad(number, along, reach, "roundrect", width, length))
            elif side == 2:
                pads.append(_pad(number, reach, -along, "roundrect", length, width))
            else:
                pads.append(_pad(number, -along, -reach, "roundrect", width, length))
    return pads


def qfn(per_side: int, pitch: float, exposed_pad: bool) -> Template:
    body = per_side * pitch + 1.0
    pads = _quad(per_side, pitch, body / 2, 0.8, QFN_PAD_WIDTH[pitch])
    if exposed_pad:
        # The exposed pad stops 0.3 mm short of the inner ends of the pins.
        side = body - 0.8 - 0.6
        pads.append(_pad(4 * per_side + 1, 0, 0, "rect", side, side))
    suffix = "-1EP" if exposed_pad else ""
    return _template(f"QFN-{4 * per_side}{suffix}_P{pitch:g}", "qfn", pads)


def qfp(per_side: int, pitch: float) -> Template:
    body = per_side * pitch + 1.0
    pads = _quad(per_side, pitch, body / 2 + 0.75, 1.5, QFP_PAD_WIDTH[pitch])
    return _template(f"QFP-{4 * per_side}_P{pitch:g}", "qfp", pads)


def pin_header(rows: int, n: int) -> Template:
    """rows x n pins at 2.54 mm, 1.7 mm pads on 1.0 mm holes, pin 1 square."""
    pads = []
    for i in range(n):
        for r in range(rows):
            number = i * rows + r + 1
            x = (r - (rows - 1) / 2) * 2.54
            y = (i - (n - 1) / 2) * 2.54
            pads.append(_pad(number, x, y, "rect" if number == 1 else "circle", 1.7, 1.7, 1.0))
    return _template(f"PinHeader_{rows}x{n:02d}_P2.54", "header", pads)


def jst_ph(n: int) -> Template:
    """A 2.0 mm pitch through-hole wire-to-board connector."""
    return _template(f"JST_PH_1x{n:02d}_P2.0", "connector", _tht_row(n, 2.0, 1.2, 0.75))


def jst_sh(n: int) -> Template:
    """A 1.0 mm pitch SMD connector with two mounting tabs (unconnected pads)."""
    first = (n - 1) * 1.0 / 2
    pads = [_pad(i + 1, -first + i, -1.3, "roundrect", 0.6, 1.55) for i in range(n)]
    tab_x = first + 1.7
    pads += [_pad("MP", -tab_x, 1.2, "roundrect", 1.2, 1.8),
             _pad("MP", tab_x, 1.2, "roundrect", 1.2, 1.8)]
    return _template(f"JST_SH_1x{n:02d}_P1.0", "connector", pads)


def terminal_block(n: int) -> Template:
    """A 5.08 mm pitch screw terminal."""
    return _template(f"TerminalBlock_1x{n:02d}_P5.08", "connector", _tht_row(n, 5.08, 2.6, 1.3))


def _tht_row(n: int, pitch: float, size: float, drill: float) -> list:
    """n through-hole pads in a row centred on the origin, pin 1 square."""
    first = (n - 1) * pitch / 2
    return [_pad(i + 1, -first + pitch * i, 0, "rect" if i == 0 else "circle", size, size, drill)
            for i in range(n)]


def mounting_hole(drill_mm: float) -> Template:
    pads = [_pad("", 0, 0, "circle", drill_mm, drill_mm, drill_mm, plated=False)]
    return _template(f"MountingHole_{drill_mm:g}mm", "hole", pads)


def min_gap(template: Template) -> int:
    """The smallest copper gap between two pads of a template (nm), from their bounding boxes
    (exact for the rectangular and round pads of this library laid out in rows)."""
    best = None
    pads = template.pads
    for i, a in enumerate(pads):
        for b in pads[:i]:
            gap_x = abs(a.dx - b.dx) - (a.width + b.width) // 2
            gap_y = abs(a.dy - b.dy) - (a.height + b.height) // 2
            gap = max(gap_x, gap_y)
            best = gap if best is None else min(best, gap)
    return best if best is not None else 1 << 40


def min_pitch(template: Template) -> int:
    """The smallest centre distance of two pads (nm; squared distance rounded down)."""
    best = None
    pads = template.pads
    for i, a in enumerate(pads):
        for b in pads[:i]:
            d = (a.dx - b.dx) ** 2 + (a.dy - b.dy) ** 2
            best = d if best is None else min(best, d)
    return int(best ** 0.5) if best is not None else 0


# --- package variants (`package_variety`) ------------------------------------------------
# Real boards take each kind of part in many packages: a transistor is a SOT-23-5 or a SOT-223
# as well as a SOT-23, a connector one of dozens of families, a radial part a capacitor of any
# pin distance, an LED, a crystal. A part drawn as a variant gets one of these.
#: Axial lead spacings of resistors, diodes and inductors, mm.
AXIAL_VARIANT_PITCHES = (5.08, 7.62, 10.16, 12.7, 15.24)
#: Radial parts: (name, pins, pin distance range mm, pad size, drill): capacitors, LEDs,
#: crystals, TO-92 transistors (inline).
RADIAL_VARIANTS = (("CP_Radial", 2, (2.0, 7.5), 1.6, 0.8), ("LED_THT", 2, (2.54, 2.54), 1.8, 0.9),
                   ("Crystal_HC49", 2, (4.88, 4.88), 1.5, 0.8),
                   ("TO-92", 3, (1.27, 1.27), 1.05, 0.75))
#: Connector families besides `jst_ph`, `jst_sh`, `terminal_block`: (name, pitch mm, pad size,
#: drill, pins from, to).
THT_CONNECTORS = (("JST_XH", 2.5, 1.7, 0.95, 2, 8), ("Molex_KK396", 3.96, 2.5, 1.5, 2, 6),
                  ("TerminalBlock_P3.5", 3.5, 2.2, 1.2, 2, 6),
                  ("TerminalBlock_P3.81", 3.81, 2.2, 1.2, 2, 6),
                  ("TerminalBlock_P5.0", 5.0, 2.6, 1.3, 2, 4),
                  ("PinHeader_P2.00", 2.0, 1.35, 0.8, 2, 10))


def radial_variant(name: str, pins: int, pitch_mm: float, size: float, drill: float) -> Template:
    """A through-hole part of `pins` pins in a row `pitch_mm` apart (`RADIAL_VARIANTS`; a
    three-pin one is a transistor, referenced as one)."""
    kind = "sot23" if pins == 3 else "radial"
    return _template(f"{name}_P{pitch_mm:g}", kind, _tht_row(pins, pitch_mm, size, drill))


def tht_connector(name: str, pitch_mm: float, size: float, drill: float, n: int) -> Template:
    """A through-hole connector of `THT_CONNECTORS`: n pins in a row."""
    return _template(f"{name}_1x{n:02d}", "connector", _tht_row(n, pitch_mm, size, drill))


def sot_variant(name: str) -> Template:
    """Small transistor and regulator packages besides the SOT-23: SOT-23-5 and -6 (0.95 mm
    pins), SC-70 (1.3 mm between pins 1 and 2), SOT-89 (1.5 mm, a tab), SOT-223 (2.3 mm, a
    tab)."""
    if name in ("SOT-23-5", "SOT-23-6"):
        pads = [_pad(i + 1, -1.1, (i - 1) * 0.95, "roundrect", 1.06, 0.6) for i in range(3)]
        right = (-0.95, 0.95) if name == "SOT-23-5" else (-0.95, 0.0, 0.95)
        pads += [_pad(4 + i, 1.1, y, "roundrect", 1.06, 0.6) for i, y in enumerate(right)]
    elif name == "SC-70":
        pads = [_pad(1, -0.95, 0.65, "roundrect", 0.9, 0.45),
                _pad(2, -0.95, -0.65, "roundrect", 0.9, 0.45),
                _pad(3, 0.95, 0.0, "roundrect", 0.9, 0.45)]
    elif name == "SOT-89":
        pads = [_pad(i + 1, (i - 1) * 1.5, 1.9, "roundrect", 0.6, 1.4) for i in range(3)]
        pads.append(_pad(4, 0, -0.75, "rect", 2.2, 2.4))
    else:  # SOT-223
        pads = [_pad(i + 1, (i - 1) * 2.3, 3.15, "roundrect", 1.0, 1.9) for i in range(3)]
        pads.append(_pad(4, 0, -3.15, "rect", 3.3, 1.9))
    return _template(name, "sot23", pads)


SOT_VARIANTS = ("SOT-23-5", "SOT-23-6", "SC-70", "SOT-89", "SOT-223")


def variant_templates() -> list[Template]:
    """One template of every variant at the ends of its ranges (for the parameters' gap
    check)."""
    out = [radial_variant(n, k, r, s, d) for n, k, rng, s, d in RADIAL_VARIANTS for r in rng]
    out += [tht_connector(n, p, s, d, 2) for n, p, s, d, _, _ in THT_CONNECTORS]
    out += [sot_variant(n) for n in SOT_VARIANTS]
    out += [axial(p) for p in AXIAL_VARIANT_PITCHES]
    return out

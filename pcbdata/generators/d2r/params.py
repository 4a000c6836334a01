"""The parameters of the realistic family (`d2r`), typed and checked before anything is made."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from pcbdata.core.errors import UserError
from pcbdata.generators.base import KICAD_HOLE_CLEARANCE_MM, KICAD_MIN_ANNULAR_MM, MAX_LENGTH_MM
from pcbdata.generators.d2r import footprints as fp
from pcbdata.generators.d2r.layout import OUTLINE_SHAPES
from pcbdata.generators.params import GeneratorParams
from pcbdata.kicad.drc_report import UNCONNECTED_LIST_CAP
from pcbdata.model.board import nm_to_mm

# Plated holes of the library (headers 1.0, JST PH 0.75, terminal blocks 1.3 mm): a class's
# hole minimum applies to pad holes too, so via drills stay at or below the smallest.
SMALLEST_PAD_DRILL_MM = 0.75
# KiCad 9's DRC report lists at most 499 unconnected items, so the build's check could not
# confirm a board with more missing connections than that.
KICAD_MAX_UNCONNECTED = UNCONNECTED_LIST_CAP
_PROBABILITY_TABLES = ("part_mix", "passive_sizes", "outline_mix", "signal_net_sizes")
_FRACTIONS = ("passive_size_consistency", "back_side_fraction",
              "four_layer_fraction", "exposed_pad_fraction", "mounting_hole_fraction",
              "decoupling_fraction", "connected_fraction", "two_row_header_fraction",
              "fill_style_coupling", "top_up_by_pins", "packed_fraction",
              "land_pattern_spread", "land_pattern_library", "package_variety")
_CLASS_LENGTHS = ("clearance_mm", "track_width_mm", "via_diameter_mm", "via_drill_mm")
#: A board's draws that `joint_correlation` can correlate: its part count, pads per part, style
#: tilt, fill, power share (`power_spread`), net size tilt (`net_size_spread`) and layer count.
JOINT_DRAWS = ("components", "pads_per_component", "style", "fill", "power", "net_sizes",
               "layers")


@dataclass(frozen=True)
class D2RParams(GeneratorParams):
    """Every knob of a realistic board; lengths in mm. The defaults are level `b`'s (D3-B);
    docs/realistic.md explains each."""

    components_median: float = 17.0
    components_sigma: float = 0.5
    components_range: tuple[int, int] = (4, 45)
    pads_per_component_median: float = 3.2
    pads_per_component_sigma: float = 0.15
    pads_range: tuple[int, int] = (38, 90)
    part_mix: dict[str, float] = field(default_factory=lambda: {
        "passive": 0.283, "axial": 0.14, "radial": 0.13, "sot23": 0.06, "soic": 0.06,
        "tssop": 0.008, "dip": 0.07, "qfn": 0.005, "qfp": 0.004, "header": 0.16,
        "connector": 0.08})
    style_spread: float = 1.0
    top_up_by_pins: float = 0.0
    passive_sizes: dict[str, float] = field(default_factory=lambda: {
        "0402": 0.15, "0603": 0.35, "0805": 0.3, "1206": 0.2})
    passive_size_consistency: float = 0.8
    #: The share of boards whose passives come from another land-pattern library: one pad
    #: centre distance per size drawn from its published range (0: every board nominal).
    land_pattern_spread: float = 0.0
    #: Of those boards, the share taking one distance per size from published libraries'
    #: values (`fp.PASSIVE_LIBRARY_PITCHES_MM`) instead of uniform in the range (0: none, no
    #: draw).
    land_pattern_library: float = 0.0
    #: The share of passives, axial and radial parts, SOT-23s, headers and connectors drawn
    #: in another package of their kind (`parts._variant`: diodes, 2.0 mm headers, connector
    #: families, ...; 0: none, no draw).
    package_variety: float = 0.0
    qfn_pitches_mm: tuple[float, ...] = (0.4, 0.5, 0.65)
    qfp_pitches_mm: tuple[float, ...] = (0.4, 0.5, 0.65, 0.8)
    radial_pitches_mm: tuple[float, ...] = (2.5, 3.5, 5.0)
    exposed_pad_fraction: float = 0.7
    header_pins: tuple[int, int] = (2, 8)
    two_row_header_fraction: float = 0.25
    back_side_fraction: float = 0.35
    four_layer_fraction: float = 0.02
    fill_range: tuple[float, float] = (0.1, 2.0)
    fill_style_coupling: float = 0.0
    packed_fraction: float = 0.0
    packed_margin_mm: tuple[float, float] = (0.5, 2.0)
    aspect_range: tuple[float, float] = (1.0, 1.8)
    outline_mix: dict[str, float] = field(default_factory=lambda: {
        "rect": 0.5, "rounded": 0.2, "chamfered": 0.1, "l_shape": 0.1, "notch": 0.1})
    corner_mm: tuple[float, float] = (1.0, 4.0)
    mounting_hole_fraction: float = 0.2
    mounting_hole_drill_mm: float = 3.2
    power_rails: tuple[int, ...] = (1, 2)
    decoupling_fraction: float = 0.4
    connected_fraction: float = 0.8
    signal_net_sizes: dict[str, float] = field(default_factory=lambda: {
        "2": 0.7, "3": 0.18, "4": 0.07, "5": 0.035, "6": 0.015})
    #: Per board, signal net sizes tilted by exp(t * (size - 2)), t uniform in [-spread,
    #: spread]: boards of mostly two-pad nets and boards of larger ones (0: the table as is).
    net_size_spread: float = 1.0
    #: Per board, `decoupling_fraction` scaled by a factor uniform in [1 - spread, 1 + spread]
    #: (at most 1): boards with few power pins and boards with many (0: the level's fraction).
    power_spread: float = 0.5
    #: Pairwise correlations of a board's `JOINT_DRAWS`, {"fill:power" = 0.3, ...}: the board
    #: draws them together, as one Gaussian vector with these correlations (a Gaussian copula:
    #: each draw keeps its own distribution), instead of one by one (empty: independent, no
    #: joint draw).
    joint_correlation: dict[str, float] = field(default_factory=dict)
    locality: int = 4
    max_connections: int = KICAD_MAX_UNCONNECTED
    compactness: int = 4
    edge_clearance_mm: float = 0.5
    courtyard_gap_mm: float = 0.1
    placement_grid_mm: float = 0.05
    clearance_mm: float = 0.15
    track_width_mm: float = 0.15
    via_diameter_mm: float = 0.6
    via_drill_mm: float = 0.3
    power_clearance_mm: float = 0.15
    power_track_width_mm: float = 0.25
    power_via_diameter_mm: float = 0.8
    power_via_drill_mm: float = 0.4

    LABEL = "d2r"
    RECORDED_WHEN_SET = ("land_pattern_spread", "land_pattern_library", "package_variety",
                         "joint_correlation")

    @staticmethod
    def coerce(key: str, value, annotation: str, where: str):
        return _coerce(key, value, annotation, where)

    def __post_init__(self) -> None:
        problems = (self._ranges() or self._tables() or self._joint() or self._lengths()
                    or self._rules())
        if problems:
            raise UserError("invalid d2r parameters: " + "; ".join(problems))

    def _ranges(self) -> list[str]:
        out = []
        low, high = self.components_range
        if not 1 <= low <= high <= 2000:
            out.append(f"components_range must be [low, high] with 1 <= low <= high <= 2000, "
                       f"got {[low, high]}")
        if not low <= self.components_median <= high:
            out.append(f"components_median must lie in components_range, got "
                       f"{self.components_median}")
        if not 0 <= self.style_spread <= 2:
            out.append(f"style_spread must be from 0 to 2, got {self.style_spread}")
        if not 0 <= self.net_size_spread <= 2:
            out.append(f"net_size_spread must be from 0 to 2, got {self.net_size_spread}")
        if not 0 <= self.power_spread <= 1:
            out.append(f"power_spread must be from 0 to 1, got {self.power_spread}")
        for name in ("components_sigma", "pads_per_component_sigma"):
            if not 0 <= getattr(self, name) <= 3:
                out.append(f"{name} must be from 0 to 3, got {getattr(self, name)}")
        if not 0.5 <= self.pads_per_component_median <= 100:
            out.append(f"pads_per_component_median must be from 0.5 to 100, got "
                       f"{self.pads_per_component_median}")
        for name in _FRACTIONS:
            if not 0 <= getattr(self, name) <= 1:
                out.append(f"{name} must be in [0, 1], got {getattr(self, name)}")
        for name, lo_bound, hi_bound in (("pads_range", 2, 100_000), ("fill_range", 0.01, 2.0),
                                         ("aspect_range", 1.0, 5.0), ("corner_mm", 0.1, 20.0),
                                         ("header_pins", 2, 40),
                                         ("packed_margin_mm", 0.0, 50.0)):
            lo, hi = getattr(self, name)
            if not lo_bound <= lo <= hi <= hi_bound:
                out.append(f"{name} must be [low, high] with {lo_bound:g} <= low <= high <= "
                           f"{hi_bound:g}, got {[lo, hi]}")
        if not self.power_rails or min(self.power_rails) < 0 or max(self.power_rails) > 4:
            out.append(f"power_rails must list rail counts from 0 to 4, got "
                       f"{list(self.power_rails)}")
        if not 1 <= self.max_connections <= KICAD_MAX_UNCONNECTED:
            out.append(f"max_connections must be from 1 to {KICAD_MAX_UNCONNECTED} (KiCad's DRC "
                       f"reports at most {KICAD_MAX_UNCONNECTED} unconnected items), got "
                       f"{self.max_connections}")
        for name in ("locality", "compactness"):
            if not 1 <= getattr(self, name) <= 100:
                out.append(f"{name} must be from 1 to 100, got {getattr(self, name)}")
        return out

    def _tables(self) -> list[str]:
        out = []
        allowed = {"part_mix": fp.KINDS, "passive_sizes": tuple(fp.PASSIVES),
                   "outline_mix": OUTLINE_SHAPES}
        for name in _PROBABILITY_TABLES:
            table: dict[str, float] = getattr(self, name)
            keys = allowed.get(name)
            for key, p in table.items():
                if keys is not None and key not in keys:
                    out.append(f"{name}: unknown key {key!r} (keys: {', '.join(keys)})")
                elif keys is None and not (key.isdigit() and 2 <= int(key) <= 64):
                    out.append(f"{name}: keys are net sizes from 2 to 64, got {key!r}")
                if p < 0:
                    out.append(f"{name}: probabilities must be >= 0, got {key}: {p}")
            if abs(math.fsum(table.values()) - 1) > 1e-9:
                out.append(f"{name} probabilities must sum to 1, got "
                           f"{math.fsum(table.values()):g}")
        for name, widths in (("qfn_pitches_mm", fp.QFN_PAD_WIDTH),
                             ("qfp_pitches_mm", fp.QFP_PAD_WIDTH)):
            values = getattr(self, name)
            if not values or any(v not in widths for v in values):
                out.append(f"{name} must list pitches among {sorted(widths)}, got {list(values)}")
        low, high = fp.RADIAL_PITCH_RANGE_MM
        if not self.radial_pitches_mm or any(not low <= v <= high for v in self.radial_pitches_mm):
            out.append(f"radial_pitches_mm must list pitches from {low:g} to {high:g} mm, got "
                       f"{list(self.radial_pitches_mm)}")
        return out

    def _joint(self) -> list[str]:
        out = []
        pairs: dict[frozenset[str], str] = {}
        for key, value in self.joint_correlation.items():
            names = key.split(":")
            if len(names) != 2 or names[0] == names[1] or any(
                    n not in JOINT_DRAWS for n in names):
                out.append(f"joint_correlation: keys are two different draws 'a:b' of "
                           f"{', '.join(JOINT_DRAWS)}, got {key!r}")
                continue
            first = pairs.setdefault(frozenset(names), key)
            if first != key:
                out.append(f"joint_correlation: {first!r} and {key!r} name the same pair")
            elif not -1 < value < 1:
                out.append(f"joint_correlation: {key} must lie strictly between -1 and 1, got "
                           f"{value}")
        if not out and self.joint_correlation and joint_factor(self.joint_correlation) is None:
            out.append("joint_correlation: these correlations do not fit together (the matrix "
                       "they make is not positive definite)")
        return out

    def _lengths(self) -> list[str]:
        out = []
        names = [f"power_{n}" for n in _CLASS_LENGTHS] + list(_CLASS_LENGTHS) + [
            "mounting_hole_drill_mm", "placement_grid_mm"]
        for name in names:
            if not 0.01 <= getattr(self, name) <= 10:
                out.append(f"{name} must be from 0.01 to 10 mm, got {getattr(self, name)}")
        for name in ("edge_clearance_mm", "courtyard_gap_mm"):
            if not 0 <= getattr(self, name) <= MAX_LENGTH_MM:
                out.append(f"{name} must be from 0 to {MAX_LENGTH_MM:g} mm, got "
                           f"{getattr(self, name)}")
        return out

    def _rules(self) -> list[str]:
        """Net classes KiCad's DRC can hold every generated board to."""
        out = []
        for prefix in ("", "power_"):
            diameter = getattr(self, f"{prefix}via_diameter_mm")
            drill = getattr(self, f"{prefix}via_drill_mm")
            if diameter - drill < 2 * KICAD_MIN_ANNULAR_MM - 1e-7:
                out.append(f"{prefix}vias {diameter}/{drill} mm leave an annular ring under "
                           f"KiCad's minimum {KICAD_MIN_ANNULAR_MM} mm")
            if drill > SMALLEST_PAD_DRILL_MM:
                out.append(f"{prefix}via_drill_mm {drill} is above the library's smallest pad "
                           f"hole {SMALLEST_PAD_DRILL_MM} mm (KiCad holds pad holes to it too)")
        for name in _CLASS_LENGTHS:
            if getattr(self, f"power_{name}") < getattr(self, name):
                out.append(f"power_{name} must not be below {name}: the Default class is the "
                           f"finest (the board's minima are its)")
        clearance = max(self.clearance_mm, self.power_clearance_mm)
        gap = self.smallest_pad_gap_mm()
        if gap < clearance - 1e-7:
            out.append(f"clearance {clearance} mm is above the library's smallest gap between "
                       f"pads of one footprint, {gap:g} mm, at these pitches")
        between = 2 * fp.COURTYARD_MARGIN_MM + self.courtyard_gap_mm
        if between < max(clearance, KICAD_HOLE_CLEARANCE_MM) - 1e-7:
            out.append(f"courtyard_gap_mm {self.courtyard_gap_mm} leaves {between:g} mm between "
                       f"parts, under the clearance or KiCad's hole clearance")
        return out

    def smallest_pad_gap_mm(self) -> float:
        """The smallest copper gap inside any footprint these parameters can place."""
        templates = [fp.qfn(4, p, True) for p in self.qfn_pitches_mm]
        templates += [fp.qfp(8, p) for p in self.qfp_pitches_mm]
        templates += [fp.passive(s) for s in fp.PASSIVES] + [fp.tssop(8), fp.soic(8)]
        if self.land_pattern_spread:
            templates += [fp.passive(s, fp.PASSIVE_PITCH_RANGES_MM[s][0]) for s in fp.PASSIVES]
        if self.land_pattern_spread and self.land_pattern_library:
            templates += [fp.passive(s, min(fp.PASSIVE_LIBRARY_PITCHES_MM[s]))
                          for s in fp.PASSIVES]
        if self.package_variety:
            templates += fp.variant_templates()
        templates += [fp.sot23(), fp.pin_header(2, 2), fp.jst_ph(2), fp.jst_sh(2),
                      fp.terminal_block(2), fp.dip(8)]
        templates += [fp.axial(p) for p in fp.AXIAL_PITCHES]
        templates += [fp.radial(p) for p in self.radial_pitches_mm]
        return nm_to_mm(min(fp.min_gap(t) for t in templates))



def _coerce(key: str, value, annotation: str, where: str):
    def bad(expected: str):
        shown = repr(value) if len(repr(value)) <= 80 else repr(value)[:77] + "..."
        return UserError(f"{where}: d2r parameter {key!r} must be {expected}, got {shown}")

    def number(v, integer: bool = False):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (
                integer and not isinstance(v, int)):
            raise bad("an integer" if integer else "a number")
        if integer:
            return v
        try:
            out = float(v)
        except OverflowError:
            out = math.inf
        if not math.isfinite(out):
            raise bad("finite (nan and inf are not sizes or probabilities)")
        return out

    def items(v, length: int | None):
        if not isinstance(v, (list, tuple)) or (length is not None and len(v) != length):
            raise bad("a range [low, high]" if length == 2 else "a list")
        return v

    if annotation in ("float", "int"):
        return number(value, annotation == "int")
    if annotation.startswith("tuple["):
        integer = annotation.startswith("tuple[int")
        length = None if annotation.endswith("...]") else 2
        return tuple(number(v, integer) for v in items(value, length))
    if annotation == "dict[str, float]":
        if not isinstance(value, dict):
            raise bad("a table {key = number, ...}")
        return {str(k): number(v) for k, v in value.items()}
    raise AssertionError(f"no coercion for {annotation}")  # pragma: no cover


def joint_matrix(correlation: dict[str, float]) -> list[list[float]]:
    """The correlation matrix over `JOINT_DRAWS` that `joint_correlation` gives (pairs not
    named: 0)."""
    index = {name: i for i, name in enumerate(JOINT_DRAWS)}
    matrix = [[1.0 if i == j else 0.0 for j in range(len(JOINT_DRAWS))]
              for i in range(len(JOINT_DRAWS))]
    for key, value in correlation.items():
        a, b = (index[n] for n in key.split(":"))
        matrix[a][b] = matrix[b][a] = float(value)
    return matrix


def joint_factor(correlation: dict[str, float]) -> list[list[float]] | None:
    """The lower Cholesky factor of `joint_matrix` in plain floats (the same on every machine),
    or None when the matrix is not positive definite."""
    matrix = joint_matrix(correlation)
    size = len(matrix)
    factor = [[0.0] * size for _ in range(size)]
    for i in range(size):
        for j in range(i + 1):
            rest = matrix[i][j] - math.fsum(factor[i][k] * factor[j][k] for k in range(j))
            if i == j:
                if rest <= 1e-9:
                    return None
                factor[i][i] = math.sqrt(rest)
            else:
                factor[i][j] = rest / factor[j][j]
    return factor

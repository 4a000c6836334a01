"""D2R: realistic synthetic boards, calibrated to the D3 tiers (SPEC section 2b).

Multi-pad parts from a parametric footprint library (`footprints`, drawn by `d2r_parts`),
placed on both sides at 0, 90, 180 or 270 degrees with disjoint courtyards, inside rectangular
or shaped outlines with mounting holes, or packed together and the outline cut around them
(`d2r_layout`); power nets touching many pins, signal
nets joining pins of nearby parts, unconnected pins; a `Power` net class with its own
clearance, track and via, enforced by the project and by a rule in the board's `.kicad_dru`;
2 or 4 copper layers.
"""
from __future__ import annotations

import math
from dataclasses import replace

from pcbdata.core.errors import GenerationError
from pcbdata.core.rng import Stream, check_seed
from pcbdata.generators.base import MAX_LENGTH_MM, Instance, board_id
from pcbdata.generators.d2r import footprints as fp
from pcbdata.generators.d2r.layout import (
    Outline,
    Packer,
    Placer,
    Rect,
    bounds,
    footprint_box,
    make_outline,
    outline_length,
    round_to,
)
from pcbdata.generators.d2r.params import JOINT_DRAWS, D2RParams, joint_factor
from pcbdata.generators.d2r.parts import (
    PartDrawer,
    Style,
    joinable_pins,
    pins,
    pins_to_ask,
    weighted,
)
from pcbdata.model.board import Board, NetClass, Part, PartPad, Rules, mm_to_nm

__all__ = ["D2RGenerator", "D2RParams"]

_ATTEMPTS_PER_PART = 150
_GROWTH = 1.05  # a board whose parts do not fit is redrawn this much larger
_RESTARTS = 40
_TARGET_REDRAWS = 20
_SHAPE_ATTEMPTS = 8  # a packed board's outline: draws of its shape before a rectangle
_HOLE_MARGIN_STEP_MM = 0.5  # a packed board's margin grows by this until its holes fit
_RAILS = ("+3V3", "+5V", "+1V8", "+12V")
_THT_STYLE = ("axial", "radial", "dip")
_SMD_STYLE = ("passive", "sot23", "soic", "tssop", "qfn", "qfp")
_REF_PREFIX = {"sot23": "Q", "soic": "U", "tssop": "U", "dip": "U", "qfn": "U", "qfp": "U",
               "header": "J", "connector": "J", "axial": "R", "radial": "C"}


def _normal(stream: Stream) -> float:
    """A standard normal draw (Box-Muller) from two uniform draws."""
    u1, u2 = stream.random(), stream.random()
    return math.sqrt(-2.0 * math.log(1.0 - u1)) * math.cos(2.0 * math.pi * u2)


class _Draws:
    """A board's `JOINT_DRAWS`: with `joint_correlation`, drawn together up front as one
    Gaussian vector (its factor times independent normals); without, each from the stream when
    it is needed, as before the parameter existed (the same boards)."""

    def __init__(self, stream: Stream, factor: list[list[float]] | None):
        self.stream = stream
        self.joint: dict[str, float] = {}
        if factor is not None:
            z = [_normal(stream) for _ in JOINT_DRAWS]
            self.joint = {name: math.fsum(factor[i][k] * z[k] for k in range(i + 1))
                          for i, name in enumerate(JOINT_DRAWS)}

    def normal(self, name: str) -> float:
        return self.joint[name] if name in self.joint else _normal(self.stream)

    def share(self, name: str, fraction: float) -> bool:
        """Whether the board is among a `fraction` of boards: the joint draw in its top
        `fraction` (a higher draw, more likely), else the stream's draw below `fraction`."""
        if name in self.joint:
            return 1.0 - self.uniform(name) < fraction
        return self.stream.random() < fraction

    def uniform(self, name: str) -> float:
        """In [0, 1]: the joint draw's normal CDF, else the stream's draw."""
        if name in self.joint:
            return 0.5 * math.erfc(-self.joint[name] / math.sqrt(2.0))
        return self.stream.random()


class D2RGenerator:
    """Realistic boards. Guarantee (besides `Generator`'s): courtyards of one side never
    overlap, and a through-hole part's or mounting hole's courtyard overlaps no other; every
    courtyard lies `edge_clearance_mm` inside the outline; copper of different nets is at least
    the larger of their classes' clearances apart (the library's pad gaps are checked against
    it when the parameters are made); each net of the `Power` class is listed in the project's
    netclass patterns and ruled in the `.kicad_dru`."""

    family = "d2r"
    seed_key = 3
    routing_layers = 4

    def __init__(self, params: D2RParams | None = None):
        self.params = params or D2RParams()
        p = self.params
        self.parts = PartDrawer(p)
        self._factor = joint_factor(p.joint_correlation) if p.joint_correlation else None
        self.rules = Rules(clearance=mm_to_nm(p.clearance_mm),
                           track_width=mm_to_nm(p.track_width_mm),
                           edge_clearance=mm_to_nm(p.edge_clearance_mm),
                           via_diameter=mm_to_nm(p.via_diameter_mm),
                           via_drill=mm_to_nm(p.via_drill_mm))

    def generate(self, seed: int, split: str, index: int) -> Instance:
        check_seed(seed)
        stream = Stream(seed, self.seed_key, 0, split, index)
        p = self.params
        draws = _Draws(stream, self._factor)
        layers = 4 if draws.share("layers", p.four_layer_fraction) else 2
        count = self._component_count(draws)
        mix, smd_lean = self._board_mix(draws)
        style = Style(mix, self._board_passives(stream), smd_lean,
                      self._board_land_patterns(stream))
        templates = [self.parts.from_mix(stream, style) for _ in range(count)]
        pad_target = self._pad_target(draws, count)
        self._top_up(stream, style, templates, pad_target)
        sides = ["B" if not t.through_hole and stream.random() < p.back_side_fraction else "F"
                 for t in templates]
        holes = 4 if stream.random() < p.mounting_hole_fraction else 0
        outline, parts = self._layout(stream, templates, sides, holes, style,
                                      f"{split} {index}", draws.uniform("fill"))
        parts = _Nets(stream, p, pad_target, draws).assign(parts)
        power = tuple(n for n in ("GND", *_RAILS) if _has_net(parts, n))
        board = Board(width=outline.width, height=outline.height, rules=self.rules, pads=[],
                      uuid_seed=f"d2r/{seed}/{split}/{index}", parts=parts, copper_layers=layers,
                      outline=outline.edges, net_classes=(self._power_class(power),))
        return Instance(board_id=board_id(index), board=board)

    def _power_class(self, nets: tuple[str, ...]) -> NetClass:
        p = self.params
        return NetClass("Power", clearance=mm_to_nm(p.power_clearance_mm),
                        track_width=mm_to_nm(p.power_track_width_mm),
                        via_diameter=mm_to_nm(p.power_via_diameter_mm),
                        via_drill=mm_to_nm(p.power_via_drill_mm), nets=nets)

    def _component_count(self, draws: _Draws) -> int:
        p = self.params
        value = math.exp(math.log(p.components_median)
                         + p.components_sigma * draws.normal("components"))
        low, high = p.components_range
        return min(high, max(low, int(round(value))))

    def _pad_target(self, draws: _Draws, components: int) -> int:
        """Terminal pads to aim for: components times a lognormal ratio, within the range. A
        target outside the range is drawn again (clipping it would pile boards up at the
        range's ends, where real tiers have no such peaks), and clipped only after
        `_TARGET_REDRAWS` draws (a count far outside the range); the first draw is the board's
        joint one (`joint_correlation`), the others the stream's."""
        p = self.params
        low, high = p.pads_range
        target = low
        for attempt in range(_TARGET_REDRAWS):
            z = draws.normal("pads_per_component") if attempt == 0 else _normal(draws.stream)
            ratio = math.exp(math.log(p.pads_per_component_median)
                             + p.pads_per_component_sigma * z)
            target = int(round(components * ratio))
            if low <= target <= high:
                return target
        return min(high, max(low, target))

    def _board_mix(self, draws: _Draws) -> tuple[dict[str, float], float]:
        """The part mix of one board and its SMD lean: real boards lean through-hole or SMD as
        a whole, so the two groups' weights are tilted by one draw per board (`style_spread`
        0: no tilt; above 1 a share of the boards, growing with it, has no part of the other
        group at all, as many real boards)."""
        tilt = self.params.style_spread * (2 * draws.uniform("style") - 1)
        factor = {kind: max(0.0, 1 + tilt) for kind in _THT_STYLE}
        factor.update({kind: max(0.0, 1 - tilt) for kind in _SMD_STYLE})
        mix = {k: w * factor.get(k, 1.0) for k, w in self.params.part_mix.items()}
        lean = min(1.0, max(0.0, (1 - tilt) / 2))
        return (mix if sum(mix.values()) > 0 else dict(self.params.part_mix)), lean

    def _board_passives(self, stream: Stream) -> dict[str, float]:
        """The passive sizes of one board: designers keep to one size, so one drawn size takes
        `passive_size_consistency` of the weight."""
        p = self.params
        main = weighted(stream, p.passive_sizes)
        keep = p.passive_size_consistency
        return {k: (1 - keep) * w + (keep if k == main else 0.0)
                for k, w in p.passive_sizes.items()}

    def _board_land_patterns(self, stream: Stream) -> dict[str, float] | None:
        """The pad centre distances of this board's passives: real boards take their land
        patterns from one of many libraries, so a share `land_pattern_spread` of the boards
        gets one distance per size drawn from the size's published range
        (`fp.PASSIVE_PITCH_RANGES_MM`, to 0.01 mm), or, a share `land_pattern_library` of them,
        from published libraries' values (`fp.PASSIVE_LIBRARY_PITCHES_MM`); the others keep
        the nominal ones (no draw at 0: boards unchanged)."""
        share = self.params.land_pattern_spread
        if not share or stream.random() >= share:
            return None
        library = self.params.land_pattern_library
        if library and stream.random() < library:
            return {size: stream.choice(fp.PASSIVE_LIBRARY_PITCHES_MM[size])
                    for size in sorted(fp.PASSIVES)}
        return {size: round(stream.uniform(*fp.PASSIVE_PITCH_RANGES_MM[size]), 2)
                for size in sorted(fp.PASSIVES)}

    def _top_up(self, stream: Stream, style: Style, templates: list[fp.Template],
                target: int) -> None:
        """More parts while their pins cannot give the target of terminal pads (a board of
        three passives has six pins), within `components_range`; with `top_up_by_pins`, by
        `_top_up_by_pins` instead."""
        p = self.params
        wanted = target * 1.1  # a little slack: not every pin can join a net
        if p.top_up_by_pins:
            self._top_up_by_pins(stream, style, templates, wanted)
            return
        pad_count = sum(len(t.pads) for t in templates)
        while pad_count < wanted and len(templates) < p.components_range[1]:
            templates.append(self.parts.from_mix(stream, style))
            pad_count += len(templates[-1].pads)

    def _top_up_by_pins(self, stream: Stream, style: Style, templates: list[fp.Template],
                        wanted: float) -> None:
        """More parts while the pins nets can join (`joinable_pins`) are fewer than `wanted`;
        a share `top_up_by_pins` of them drawn by pin count (`pins_to_ask`), the others from
        the board's mix. Real small boards reach their pad count with a large connector or IC,
        not with many two-pin parts."""
        p = self.params
        counts = [pins(t) for t in templates]
        while joinable_pins(counts) < wanted and len(templates) < p.components_range[1]:
            if stream.random() < p.top_up_by_pins:
                template = self.parts.by_pins(stream, style, pins_to_ask(counts, wanted))
            else:
                template = self.parts.from_mix(stream, style)
            templates.append(template)
            counts.append(pins(template))

    def _board_size(self, stream: Stream, templates: list[fp.Template], sides: list[str],
                    fill: float) -> tuple[float, float]:
        """Width and height (nm) from the courtyard area the busier side must hold at `fill`."""
        p = self.params
        load = {"F": 0.0, "B": 0.0}
        for template, side in zip(templates, sides):
            area = 4.0 * template.courtyard[0] * template.courtyard[1]
            for s in (("F", "B") if template.through_hole else (side,)):
                load[s] += area
        area = max(load.values()) / fill
        aspect = stream.uniform(*p.aspect_range)
        # The longest part must fit one way and the widest the other (parts turn).
        margin = 2 * mm_to_nm(p.edge_clearance_mm)
        longest = max(2 * max(t.courtyard) for t in templates) + margin
        widest = max(2 * min(t.courtyard) for t in templates) + margin
        width = max(math.sqrt(area * aspect), longest)
        height = max(area / width, widest)
        return (width, height) if stream.random() < 0.5 else (height, width)

    def _fill(self, drawn_share: float, style: Style) -> float:
        """The board's fill, log-uniform in `fill_range` (real boards span a decade of
        densities), pulled towards the range's top by the board's SMD lean as far as
        `fill_style_coupling` says: dense real boards are SMD boards."""
        low, high = (math.log(v) for v in self.params.fill_range)
        drawn = low + (high - low) * drawn_share
        coupling = self.params.fill_style_coupling
        if coupling:
            drawn = (1 - coupling) * drawn + coupling * (low + style.smd_lean * (high - low))
        return math.exp(drawn)

    def _packs(self, fill: float) -> bool:
        """Whether a board of this fill is packed: its fill lies in the top `packed_fraction`
        of `fill_range` (log scale). Those are the boards meant to be the densest, which random
        spots cannot make (they cover at most about two thirds of a board); with
        `fill_style_coupling` they are mostly SMD boards, as the densest real ones."""
        share = self.params.packed_fraction
        if not share:
            return False
        low, high = (math.log(v) for v in self.params.fill_range)
        return math.log(fill) >= high - share * (high - low)

    def _layout(self, stream: Stream, templates: list[fp.Template], sides: list[str],
                holes: int, style: Style, label: str,
                fill_share: float) -> tuple[Outline, list[Part]]:
        p = self.params
        # Big parts first: small ones fill the gaps left between them.
        order = sorted(range(len(templates)), key=lambda i: (
            -templates[i].courtyard[0] * templates[i].courtyard[1], i))
        fill = self._fill(fill_share, style)
        if self._packs(fill):
            return self._packed_layout(stream, templates, sides, holes, order)
        width, height = self._board_size(stream, templates, sides, fill)
        shape = weighted(stream, p.outline_mix)
        for _ in range(_RESTARTS):
            if max(width, height) > mm_to_nm(MAX_LENGTH_MM):
                break  # KiCad holds coordinates to about 2 m; boards stay within 1 m
            outline = make_outline(stream, shape, int(width), int(height), p.corner_mm)
            parts = self._place(stream, outline, templates, sides, holes, order)
            if parts is not None:
                return outline, parts
            width, height = width * _GROWTH, height * _GROWTH
        raise GenerationError(f"d2r board {label}: could not place {len(templates)} parts on "
                              f"boards up to {_RESTARTS} times 5 % larger (or {MAX_LENGTH_MM:g} "
                              f"mm); parameters: {p.as_dict()}")

    def _place(self, stream: Stream, outline: Outline, templates: list[fp.Template],
               sides: list[str], holes: int, order: list[int]) -> list[Part] | None:
        p = self.params
        placer = Placer(outline, mm_to_nm(p.edge_clearance_mm), mm_to_nm(p.courtyard_gap_mm),
                        mm_to_nm(p.placement_grid_mm))
        hole = fp.mounting_hole(p.mounting_hole_drill_mm)
        parts: list[Part] = []
        for corner in range(holes):
            placed_hole = placer.place_hole(hole, corner, f"H{len(parts) + 1}")
            if placed_hole is not None:
                parts.append(placed_hole)
        counters: dict[str, int] = {}
        placed: dict[int, Part] = {}
        for i in order:
            part = placer.try_place(stream, templates[i], sides[i], _ATTEMPTS_PER_PART,
                                    _reference(stream, templates[i], counters), p.compactness)
            if part is None:
                return None
            placed[i] = part
        return parts + [placed[i] for i in range(len(templates))]

    def _packed_layout(self, stream: Stream, templates: list[fp.Template], sides: list[str],
                       holes: int, order: list[int]) -> tuple[Outline, list[Part]]:
        """A board cut around its parts (`packed_fraction` of the boards): parts packed
        together first (`Packer`), then the outline fitted around them `packed_margin_mm`
        away. Real D3-A's densest boards are small breakouts cut around their parts; random
        spots on a board sized beforehand leave half of it empty."""
        p = self.params
        shape = weighted(stream, p.outline_mix)
        edge, grid = mm_to_nm(p.edge_clearance_mm), mm_to_nm(p.placement_grid_mm)
        # At least the edge clearance plus a grid step (parts are centred on the grid).
        margin = max(mm_to_nm(stream.uniform(*p.packed_margin_mm)), edge + grid)
        packer = Packer(mm_to_nm(p.courtyard_gap_mm), grid, margin, p.aspect_range[1])
        counters: dict[str, int] = {}
        placed = {i: packer.place(stream, templates[i], sides[i],
                                  _reference(stream, templates[i], counters)) for i in order}
        parts = [placed[i] for i in range(len(templates))]
        return self._fit_outline(stream, shape, parts, bounds(packer.placed), margin, holes)

    def _fit_outline(self, stream: Stream, shape: str, parts: list[Part], box: Rect,
                     margin: int, holes: int) -> tuple[Outline, list[Part]]:
        """An outline of `shape` around the packed parts (`box`: their courtyards' bounding
        box), `margin` away from it, its rounded or chamfered corners no larger than the margin
        leaves room for (`_corner_range`). A drawn shape that would cut into a part (an
        L-shape's or a notch's cut-out) is drawn again, and after `_SHAPE_ATTEMPTS` the board
        is a rectangle; a board with mounting holes grows its margin in steps until the holes
        fit its corners (on a rectangle they surely do at `roomy`)."""
        p = self.params
        edge, gap = mm_to_nm(p.edge_clearance_mm), mm_to_nm(p.courtyard_gap_mm)
        grid = mm_to_nm(p.placement_grid_mm)
        hole = fp.mounting_hole(p.mounting_hole_drill_mm)
        roomy = edge + 2 * max(hole.courtyard) + gap + grid
        margins = [margin]
        while holes and margins[-1] < roomy + mm_to_nm(p.corner_mm[0]):
            margins.append(margins[-1] + mm_to_nm(_HOLE_MARGIN_STEP_MM))
        for m in margins:
            # With holes, a corner must also leave room for a hole between it and the parts.
            corners = self._corner_range(m - (roomy - edge - grid if holes else 0))
            for attempt in range(_SHAPE_ATTEMPTS):
                drawn = shape if attempt < _SHAPE_ATTEMPTS - 1 else "rect"
                outline = make_outline(stream, drawn, outline_length(box[2] - box[0] + 2 * m),
                                       outline_length(box[3] - box[1] + 2 * m), corners)
                shift = (round_to((outline.width - box[2] - box[0]) / 2, grid),
                         round_to((outline.height - box[3] - box[1]) / 2, grid))
                fitted = self._fitted(outline, parts, shift, holes, hole)
                if fitted is not None:
                    return outline, fitted
        raise AssertionError("a rectangle with room for the holes always fits")  # pragma: no cover

    def _corner_range(self, room: int) -> tuple[float, float]:
        """`corner_mm`, capped to the corner that clears a part in the corner of the parts'
        box when `room` (nm) lies between that box and the outline (less the edge clearance
        and a grid step: parts are centred on the grid), on the outline's 0.1 mm grid."""
        p = self.params
        cap = (room - mm_to_nm(p.edge_clearance_mm) - mm_to_nm(p.placement_grid_mm)) // 100_000
        cap_mm = max(0.1, cap / 10)
        low, high = p.corner_mm
        return min(low, cap_mm), min(high, cap_mm)

    def _fitted(self, outline: Outline, parts: list[Part], shift: tuple[int, int],
                holes: int, hole: fp.Template) -> list[Part] | None:
        """The parts moved by `shift` and the mounting holes in `outline`'s corners, if every
        courtyard keeps its edge clearance and the holes all fit; else None."""
        p = self.params
        placer = Placer(outline, mm_to_nm(p.edge_clearance_mm), mm_to_nm(p.courtyard_gap_mm),
                        mm_to_nm(p.placement_grid_mm))
        moved = [replace(part, x=part.x + shift[0], y=part.y + shift[1]) for part in parts]
        for part in moved:
            box = footprint_box(part.x, part.y, part.courtyard, part.rotation)
            sides = ("F", "B") if part.through_hole else (part.side,)
            if not placer.fits(box, sides):
                return None
            placer.add(box, sides)
        placed_holes = [placer.place_hole(hole, corner, f"H{corner + 1}")
                        for corner in range(holes)]
        if any(h is None for h in placed_holes):
            return None
        return [h for h in placed_holes if h is not None] + moved


def _reference(stream: Stream, template: fp.Template, counters: dict[str, int]) -> str:
    """The next reference of the template's kind (a passive is an R or a C by one draw)."""
    prefix = _REF_PREFIX.get(template.kind) or ("R" if stream.random() < 0.5 else "C")
    counters[prefix] = counters.get(prefix, 0) + 1
    return f"{prefix}{counters[prefix]}"


def _has_net(parts: list[Part], net: str) -> bool:
    return any(pad.net == net for part in parts for pad in part.pads)


def _kind(part: Part) -> str:
    head = part.ref.rstrip("0123456789")
    return {"U": "ic", "Q": "ic", "J": "connector", "H": "hole"}.get(head, "passive")


class _Nets:
    """Net assignment: power pins first (ground and rails on ICs, connectors and decoupling
    passives), then signal nets grown from a pin to free pins of the nearest other parts until
    the board has its target of terminal pads (or no free pin is left), never more than
    `max_connections` ratsnest edges in all."""

    def __init__(self, stream: Stream, params: D2RParams, target: int, draws: _Draws):
        self.stream = stream
        self.draws = draws
        self.p = params
        self.target = target  # terminal pads: signal nets stop growing once reached
        self.nets: dict[tuple[int, int], str] = {}
        self.decoupling = params.decoupling_fraction  # this board's (`_board_decoupling`)

    def assign(self, parts: list[Part]) -> list[Part]:
        rails = _RAILS[:self.stream.choice(self.p.power_rails)]
        self.decoupling = self._board_decoupling()
        for k, part in enumerate(parts):
            self._power_pins(k, part, rails)
        self._trim_power()
        self._signals(parts)
        self._drop_lonely()
        return [replace(part, pads=tuple(
            replace(pad, net=self.nets.get((k, j), "")) for j, pad in enumerate(part.pads)))
            for k, part in enumerate(parts)]

    def _board_decoupling(self) -> float:
        """The share of this board's passives on a rail: the level's, spread per board by
        `power_spread` (no draw at 0: boards unchanged)."""
        fraction = self.p.decoupling_fraction
        if not self.p.power_spread:
            return fraction
        scale = 1 + self.p.power_spread * (2 * self.draws.uniform("power") - 1)
        return min(1.0, fraction * scale)

    def _connections(self) -> int:
        """Ratsnest edges so far: pins minus one per net."""
        return len(self.nets) - len(set(self.nets.values()))

    def _trim_power(self) -> None:
        """Power pins beyond `max_connections` (a huge board) become unconnected, the last
        assigned first."""
        excess = self._connections() - self.p.max_connections
        for pin in list(self.nets)[::-1][:max(0, excess)]:
            del self.nets[pin]

    def _free(self, k: int, part: Part) -> list[int]:
        return [j for j, pad in enumerate(part.pads)
                if (k, j) not in self.nets and pad.plated and pad.number != "MP"]

    def _power_pins(self, k: int, part: Part, rails: tuple[str, ...]) -> None:
        kind = _kind(part)
        free = self._free(k, part)
        if kind == "ic":
            exposed = [j for j in free if part.pads[j].shape == "rect" and len(free) > 4]
            for j in exposed:
                self.nets[(k, j)] = "GND"
            pins = [j for j in free if j not in exposed]
            wanted = ["GND"] + [self.stream.choice(rails)] if rails else ["GND"]
            self._some(k, pins, wanted if len(pins) >= 3 else wanted[:1])
        elif kind == "connector" and len(free) >= 2 and self.stream.random() < 0.5:
            self._some(k, free, ["GND"] + ([self.stream.choice(rails)] if rails else []))
        elif kind == "passive" and rails and self.stream.random() < self.decoupling:
            self.nets[(k, 0)] = self.stream.choice(rails)
            self.nets[(k, 1)] = "GND"

    def _some(self, k: int, pins: list[int], nets: list[str]) -> None:
        pins = list(pins)
        for net in nets:
            if not pins:
                return
            j = pins.pop(self.stream.integer(len(pins)))
            self.nets[(k, j)] = net

    def _signals(self, parts: list[Part]) -> None:
        pins = [(k, j) for k, part in enumerate(parts) for j in self._free(k, part)]
        where = {pin: parts[pin[0]].local_to_board(parts[pin[0]].pads[pin[1]].dx,
                                                   parts[pin[0]].pads[pin[1]].dy)
                 for pin in pins}
        sizes = sorted(self.p.signal_net_sizes)
        weights = self._net_size_weights(sizes)
        skipped: set[tuple[int, int]] = set()
        order = list(pins)
        for i in range(len(order) - 1, 0, -1):  # Fisher-Yates on the board's stream
            j = self.stream.integer(i + 1)
            order[i], order[j] = order[j], order[i]
        count = 0
        budget = self.p.max_connections - self._connections()
        for pin in order:
            if len(self.nets) >= self.target or budget < 1:
                return
            if pin in self.nets or pin in skipped:
                continue
            if self.stream.random() >= self.p.connected_fraction:
                skipped.add(pin)
                continue
            size = min(int(self.stream.weighted(sizes, weights)),
                       max(2, self.target - len(self.nets)), budget + 1)
            members = self._neighbours(pin, size - 1, pins, where, skipped)
            if not members:
                skipped.add(pin)
                continue
            count += 1
            budget -= len(members)
            for member in [pin, *members]:
                self.nets[member] = f"N{count}"

    def _net_size_weights(self, sizes: list[str]) -> list[float]:
        """The board's weights of the signal net sizes: the level's table, tilted towards small
        or large nets by a draw within `net_size_spread` (no draw at 0: boards unchanged)."""
        weights = [self.p.signal_net_sizes[s] for s in sizes]
        if not self.p.net_size_spread:
            return weights
        tilt = self.p.net_size_spread * (2 * self.draws.uniform("net_sizes") - 1)
        return [w * math.exp(tilt * (int(s) - 2)) for s, w in zip(sizes, weights)]

    def _neighbours(self, pin, wanted: int, pins, where, skipped) -> list[tuple[int, int]]:
        """Up to `wanted` free pins of distinct other parts, drawn from the `locality`
        nearest."""
        x, y = where[pin]
        candidates = sorted(
            ((where[q][0] - x) ** 2 + (where[q][1] - y) ** 2, q) for q in pins
            if q[0] != pin[0] and q not in self.nets and q not in skipped)
        pool: list[tuple[int, int]] = []
        used_parts = {pin[0]}
        for _, q in candidates:
            if q[0] not in used_parts:
                used_parts.add(q[0])
                pool.append(q)
            if len(pool) >= self.p.locality + wanted - 1:
                break
        chosen: list[tuple[int, int]] = []
        while pool and len(chosen) < wanted:
            chosen.append(pool.pop(self.stream.integer(min(len(pool), self.p.locality))))
        return chosen

    def _drop_lonely(self) -> None:
        """A net left with one pad (a rail on one part only) becomes an unconnected pin."""
        sizes: dict[str, int] = {}
        for net in self.nets.values():
            sizes[net] = sizes.get(net, 0) + 1
        self.nets = {pin: net for pin, net in self.nets.items() if sizes[net] >= 2}


def pad_position(part: Part, pad: PartPad) -> tuple[int, int]:
    """A pad's centre on the board (nm)."""
    return part.local_to_board(pad.dx, pad.dy)

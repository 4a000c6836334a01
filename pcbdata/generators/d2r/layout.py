"""Outlines and placement of the realistic family (`d2r`): board shapes with the regions parts
must keep out of, and courtyard-disjoint placement on both sides: at random spots of a board
(`Placer`) or packed together before the board is cut around them (`Packer`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from pcbdata.core.rng import Stream
from pcbdata.generators.d2r.footprints import Template
from pcbdata.model.board import EdgeArc, EdgeLine, Part

Rect = tuple[int, int, int, int]  # x1, y1, x2, y2 (nm), x1 < x2, y1 < y2
OUTLINE_SHAPES = ("rect", "rounded", "chamfered", "l_shape", "notch")
_STEP = 100_000  # outline dimensions on a 0.1 mm grid, as people draw them


@dataclass(frozen=True)
class Outline:
    """A board shape inside the rectangle width x height: its edges (empty: the rectangle),
    the rectangles cut away or rounded off (`keepouts`) and its area (nm^2)."""

    width: int
    height: int
    edges: tuple[EdgeLine | EdgeArc, ...]
    keepouts: tuple[Rect, ...]
    area: float


def _snap(value: float) -> int:
    return max(_STEP, int(round(value / _STEP)) * _STEP)


def _polygon(points: list[tuple[int, int]]) -> tuple[EdgeLine, ...]:
    return tuple(EdgeLine(*points[i], *points[(i + 1) % len(points)])
                 for i in range(len(points)))


def _corners(w: int, h: int) -> list[Rect]:
    """The four corner squares of side 1 as functions of a size, by corner: (x, y, dx, dy)."""
    return [(0, 0, 1, 1), (w, 0, -1, 1), (w, h, -1, -1), (0, h, 1, -1)]


def _corner_box(x: int, y: int, dx: int, dy: int, size: int) -> Rect:
    xs = sorted((x, x + dx * size))
    ys = sorted((y, y + dy * size))
    return (xs[0], ys[0], xs[1], ys[1])


def _rounded(w: int, h: int, r: int) -> Outline:
    c = r - round(r / math.sqrt(2))  # arc midpoint inset from the corner along each axis
    edges: list[EdgeLine | EdgeArc] = [
        EdgeLine(r, 0, w - r, 0), EdgeArc(w - r, 0, w - c, c, w, r),
        EdgeLine(w, r, w, h - r), EdgeArc(w, h - r, w - c, h - c, w - r, h),
        EdgeLine(w - r, h, r, h), EdgeArc(r, h, c, h - c, 0, h - r),
        EdgeLine(0, h - r, 0, r), EdgeArc(0, r, c, c, r, 0)]
    keepouts = tuple(_corner_box(*corner, r) for corner in _corners(w, h))
    return Outline(w, h, tuple(edges), keepouts, w * h - 4 * r * r * (1 - math.pi / 4))


def _chamfered(w: int, h: int, c: int) -> Outline:
    points = [(c, 0), (w - c, 0), (w, c), (w, h - c), (w - c, h), (c, h), (0, h - c), (0, c)]
    keepouts = tuple(_corner_box(*corner, c) for corner in _corners(w, h))
    return Outline(w, h, _polygon(points), keepouts, w * h - 2 * c * c)


def _l_shape(w: int, h: int, cut_w: int, cut_h: int, corner: int) -> Outline:
    """The rectangle without a cut_w x cut_h rectangle at one corner (0..3 clockwise from the
    top left): the points are those of the top-right cut, turned."""
    base = [(0, 0), (w - cut_w, 0), (w - cut_w, cut_h), (w, cut_h), (w, h), (0, h)]
    mirror_x = corner in (0, 3)
    mirror_y = corner in (2, 3)
    points = [(w - x if mirror_x else x, h - y if mirror_y else y) for x, y in base]
    if mirror_x != mirror_y:
        points.reverse()  # keep one orientation for every shape
    x1 = 0 if mirror_x else w - cut_w
    y1 = h - cut_h if mirror_y else 0
    return Outline(w, h, _polygon(points), ((x1, y1, x1 + cut_w, y1 + cut_h),),
                   w * h - cut_w * cut_h)


def _notch(w: int, h: int, notch_w: int, depth: int, at: int, bottom: bool) -> Outline:
    """A rectangular notch `notch_w` wide and `depth` deep starting at x = `at` in the top or
    bottom edge."""
    points = [(0, 0), (at, 0), (at, depth), (at + notch_w, depth), (at + notch_w, 0), (w, 0),
              (w, h), (0, h)]
    if bottom:
        points = [(x, h - y) for x, y in points]
        points.reverse()
    y1 = h - depth if bottom else 0
    return Outline(w, h, _polygon(points), ((at, y1, at + notch_w, y1 + depth),),
                   w * h - notch_w * depth)


def make_outline(stream: Stream, shape: str, width: int, height: int,
                 corner_mm: tuple[float, float]) -> Outline:
    """A board of `shape`; cut-outs take at most a quarter of a side, corners at most a tenth."""
    w, h = _snap(width), _snap(height)
    short = min(w, h)
    corner = min(_snap(stream.uniform(*corner_mm) * 1e6), _snap(short / 10))
    if shape == "rounded":
        return _rounded(w, h, corner)
    if shape == "chamfered":
        return _chamfered(w, h, corner)
    if shape == "l_shape":
        cut_w = _snap(w * stream.uniform(0.15, 0.3))
        cut_h = _snap(h * stream.uniform(0.15, 0.3))
        return _l_shape(w, h, cut_w, cut_h, stream.integer(4))
    if shape == "notch":
        notch_w = _snap(w * stream.uniform(0.1, 0.25))
        depth = _snap(h * stream.uniform(0.05, 0.15))
        at = _snap(stream.uniform(0.2, 0.8) * (w - notch_w))
        return _notch(w, h, notch_w, depth, at, stream.random() < 0.5)
    return Outline(w, h, (), (), float(w * h))


def _overlap(a: Rect, b: Rect, gap: int) -> bool:
    return a[0] < b[2] + gap and b[0] < a[2] + gap and a[1] < b[3] + gap and b[1] < a[3] + gap


def footprint_box(x: int, y: int, courtyard: tuple[int, int], rotation: int) -> Rect:
    half_w, half_h = courtyard if rotation % 180 == 0 else courtyard[::-1]
    return (x - half_w, y - half_h, x + half_w, y + half_h)


class Placer:
    """Places courtyards one by one at random: inside the outline `edge` away from its edges
    and keepouts, `gap` apart from the courtyards of the same side (a through-hole part or
    mounting hole occupies both sides), on a `grid`."""

    def __init__(self, outline: Outline, edge: int, gap: int, grid: int):
        self.outline = outline
        self.edge = edge
        self.gap = gap
        self.grid = grid
        self.boxes: dict[str, list[Rect]] = {"F": [], "B": []}

    def fits(self, box: Rect, sides: tuple[str, ...]) -> bool:
        o, e = self.outline, self.edge
        if box[0] < e or box[1] < e or box[2] > o.width - e or box[3] > o.height - e:
            return False
        if any(_overlap(box, keep, e) for keep in o.keepouts):
            return False
        return not any(_overlap(box, other, self.gap) for side in sides
                       for other in self.boxes[side])

    def add(self, box: Rect, sides: tuple[str, ...]) -> None:
        for side in sides:
            self.boxes[side].append(box)

    def try_place(self, stream: Stream, template: Template, side: str, attempts: int,
                  ref: str, candidates: int = 1) -> Part | None:
        """The part at the best of up to `candidates` free random spots (nearest the board's
        centre: parts cluster as on real boards, and dense boards fit), or None."""
        sides = ("F", "B") if template.through_hole else (side,)
        o, g = self.outline, self.grid
        best: tuple[int, int, int, int, Rect] | None = None
        found = 0
        for _ in range(attempts):
            rotation = 90 * stream.integer(4)
            x = g * stream.integer(max(1, o.width // g))
            y = g * stream.integer(max(1, o.height // g))
            box = footprint_box(x, y, template.courtyard, rotation)
            if not self.fits(box, sides):
                continue
            score = (2 * x - o.width) ** 2 + (2 * y - o.height) ** 2
            if best is None or score < best[0]:
                best = (score, x, y, rotation, box)
            found += 1
            if found >= candidates:
                break
        if best is None:
            return None
        _, x, y, rotation, box = best
        self.add(box, sides)
        return Part(ref=ref, name=template.name, x=x, y=y, pads=template.pads,
                    courtyard=template.courtyard, rotation=rotation,
                    side="F" if template.through_hole else side)  # type: ignore[arg-type]

    def place_hole(self, template: Template, corner: int, ref: str) -> Part | None:
        """A mounting hole in a corner, as close to it as the edges and keepouts allow."""
        o = self.outline
        half = template.courtyard[0]
        inset = self.edge + half + max((max(k[2] - k[0], k[3] - k[1]) for k in o.keepouts
                                        if k in _corner_keepouts(o)), default=0)
        x = inset if corner in (0, 3) else o.width - inset
        y = inset if corner in (0, 1) else o.height - inset
        box = footprint_box(x, y, template.courtyard, 0)
        if not self.fits(box, ("F", "B")):
            return None
        self.add(box, ("F", "B"))
        return Part(ref=ref, name=template.name, x=x, y=y, pads=template.pads,
                    courtyard=template.courtyard)


def _corner_keepouts(outline: Outline) -> tuple[Rect, ...]:
    """Keepouts of rounded or chamfered corners (the four of them), else none."""
    return outline.keepouts if len(outline.keepouts) == 4 else ()


def _ceil_to(value: float, step: int) -> int:
    return -int(-value // step) * step


def _floor_to(value: float, step: int) -> int:
    return int(value // step) * step


def round_to(value: float, step: int) -> int:
    return int(round(value / step)) * step


def outline_length(value: float) -> int:
    """A length of an outline fitted around parts: up to the outline grid, never shorter."""
    return max(_STEP, _ceil_to(value, _STEP))


_CELL = 2_000_000  # nm: the packer's neighbourhood squares


def _cells(box: Rect, reach: int) -> list[tuple[int, int]]:
    """The `_CELL` squares that `box` grown by `reach` touches."""
    xs = range((box[0] - reach) // _CELL, (box[2] + reach) // _CELL + 1)
    ys = range((box[1] - reach) // _CELL, (box[3] + reach) // _CELL + 1)
    return [(i, j) for i in xs for j in ys]


def bounds(boxes: list[Rect]) -> Rect:
    """The bounding box of `boxes` (at least one)."""
    return (min(b[0] for b in boxes), min(b[1] for b in boxes),
            max(b[2] for b in boxes), max(b[3] for b in boxes))


class Packer:
    """Places courtyards compactly, for a board cut around its parts afterwards: each part at
    the free spot beside or under the parts already placed that keeps the outline to come
    (their bounding box grown by `margin` on every side) smallest, counting a box longer than
    `aspect` times its width as that much wider (a strip is no board); of those the spot
    nearest the parts' centre. Free as for `Placer`: `gap` apart from the courtyards of its
    side (a through-hole part occupies both sides), on a `grid`; there is no outline yet."""

    def __init__(self, gap: int, grid: int, margin: int, aspect: float):
        self.gap = gap
        self.aspect = aspect
        self.grid = grid
        self.margin = margin
        # Per side, the courtyards by the `_CELL` squares they come within `gap` of: a spot is
        # checked against its neighbours only (most spots tried on a large board are taken).
        self.cells: dict[str, dict[tuple[int, int], list[Rect]]] = {"F": {}, "B": {}}
        self.placed: list[Rect] = []

    def place(self, stream: Stream, template: Template, side: str, ref: str) -> Part:
        """The part at the best free spot; its rotation drawn as `Placer`'s, or a quarter turn
        more where that packs tighter (one draw: all four rotations stay equally likely)."""
        sides = ("F", "B") if template.through_hole else (side,)
        drawn = 90 * stream.integer(4)
        before = bounds(self.placed) if self.placed else None
        ranked: list[tuple[tuple[int, int], int, int, int, int, Rect]] = []
        for rotation in (drawn, (drawn + 90) % 360):
            for x, y in self._spots(template.courtyard, rotation):
                box = footprint_box(x, y, template.courtyard, rotation)
                ranked.append((self._score(box, before), len(ranked), x, y, rotation, box))
        # Best first (ties: the first listed); only then is a spot checked for being free,
        # so a large board checks few. The plane is unbounded: some spot is always free.
        ranked.sort()
        _, _, x, y, rotation, box = next(r for r in ranked if self._free(r[5], sides))
        for s in sides:
            for cell in _cells(box, self.gap):
                self.cells[s].setdefault(cell, []).append(box)
        self.placed.append(box)
        return Part(ref=ref, name=template.name, x=x, y=y, pads=template.pads,
                    courtyard=template.courtyard, rotation=rotation,
                    side="F" if template.through_hole else side)  # type: ignore[arg-type]

    def _spots(self, courtyard: tuple[int, int], rotation: int) -> list[tuple[int, int]]:
        """Centres that put the courtyard against a placed one (its left, right, top or bottom,
        aligned with one of its ends, its middle or an end of all parts' bounding box), or
        right under it (the other side); the first part goes to the origin."""
        if not self.placed:
            return [(0, 0)]
        half_w, half_h = courtyard if rotation % 180 == 0 else courtyard[::-1]
        g, gap = self.grid, self.gap
        all_box = bounds(self.placed)
        spots: list[tuple[int, int]] = []
        for a in self.placed:
            ys = [round_to(v, g) for v in (a[1] + half_h, a[3] - half_h, (a[1] + a[3]) / 2,
                                            all_box[1] + half_h, all_box[3] - half_h)]
            xs = [round_to(v, g) for v in (a[0] + half_w, a[2] - half_w, (a[0] + a[2]) / 2,
                                            all_box[0] + half_w, all_box[2] - half_w)]
            right, left = _ceil_to(a[2] + gap + half_w, g), _floor_to(a[0] - gap - half_w, g)
            below, above = _ceil_to(a[3] + gap + half_h, g), _floor_to(a[1] - gap - half_h, g)
            spots += [(right, y) for y in ys] + [(left, y) for y in ys]
            spots += [(x, below) for x in xs] + [(x, above) for x in xs]
            spots.append((round_to((a[0] + a[2]) / 2, g), round_to((a[1] + a[3]) / 2, g)))
        return spots

    def _free(self, box: Rect, sides: tuple[str, ...]) -> bool:
        return not any(_overlap(box, other, self.gap) for side in sides
                       for cell in _cells(box, 0) for other in self.cells[side].get(cell, ()))

    def _score(self, box: Rect, before: Rect | None) -> tuple[int, int]:
        """(the outline's area with this box, counted as if its short side were at least the
        long side over `aspect`: a strip is no board; the box's squared distance from the
        centre of `before`, the parts' bounding box so far): smaller is better."""
        if before is None:
            return 0, 0
        m = 2 * self.margin
        width = max(before[2], box[2]) - min(before[0], box[0]) + m
        height = max(before[3], box[3]) - min(before[1], box[1]) + m
        long, short = (width, height) if width >= height else (height, width)
        area = long * max(short, int(long / self.aspect))
        dx = (box[0] + box[2]) - (before[0] + before[2])
        dy = (box[1] + box[3]) - (before[1] + before[3])
        return area, dx * dx + dy * dy

"""The clearance test of many segments against one layer's obstacles, compiled.

`pcbdata.router.clearance._Rules.failing` asks, for each segment of a batch, whether it comes
closer to an obstacle's core than that obstacle's allowed distance (`need`). Its reference
form screens (segment, obstacle) pairs with octagons in numpy and measures the pairs left with
shapely: a few hundred numpy calls per batch, which is where the searches spend their time.
This module answers the same question in one compiled pass per batch (numba), over a uniform
grid of the layer's cores:

- a pair whose boxes are apart by more than `need` is clear;
- otherwise the exact distance of the segment to the core's straight pieces (a polygonal core
  also contains an end of the segment: distance 0) is compared with `need`, and the pair is
  *violating* below `need - MARGIN`, *clear* at or above `need + MARGIN`, *unsure* between;
- a segment with a violating pair fails; one with an unsure pair and no violating one is
  handed back to the reference form, which decides it.

`MARGIN` (1e-4 nm) is far above the floats' rounding on board coordinates (about 1e-7 nm at
a metre) and far below what the router's geometry leaves between copper and its allowed
distance (its corners are rounded outwards to whole nanometres, and `need` already keeps
`clearance.TOLERANCE`), so every answer the kernel gives is the reference form's answer: the
two forms give the same searches, plans and episodes (tests/router/test_clearance_kernel.py
checks both on real boards). Without numba (or with ``PCBDATA_NO_NUMBA=1``) the reference
form runs alone, slower, with the same results.
"""
from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
import shapely

numba: Any
try:  # compiled when numba is installed (the set-up installs it)
    import numba
except ImportError:  # pragma: no cover - exercised by the PCBDATA_NO_NUMBA path instead
    numba = None

#: nm: pairs this close to their allowed distance are left to the reference form.
MARGIN = 1e-4
#: Piece kinds of a core: straight pieces only (points, lines), an area (polygon rings: a
#: segment end inside is at distance 0), or a mix the kernel does not judge (always unsure).
LINES, AREA, MIXED = 0, 1, 2


def enabled() -> bool:
    """Whether the compiled test runs (numba installed and not turned off by
    ``PCBDATA_NO_NUMBA``, read at each call so that a test can switch it)."""
    return numba is not None and os.environ.get("PCBDATA_NO_NUMBA", "") in ("", "0")


def _jit(function):
    if numba is None:
        return function
    return numba.njit(cache=True, nogil=True)(function)


def core_kind(core: shapely.Geometry) -> int:
    """LINES, AREA or MIXED for one core (see the module doc)."""
    kinds = {shapely.get_type_id(p) for p in shapely.get_parts(core) if not p.is_empty}
    polygons = {3}  # shapely type id of Polygon
    if not kinds or kinds <= {0, 1, 2}:  # points, lines, rings
        return LINES
    return AREA if kinds <= polygons else MIXED


class GridIndex:
    """One layer's cores as straight pieces (`pieces`, per item `start`..`end`), their kinds
    and bounding boxes, in a uniform grid of cells (compressed rows: the items of cell c are
    `items[first[c]:first[c + 1]]`)."""

    def __init__(self, pieces: np.ndarray, owner: np.ndarray, kinds: np.ndarray):
        n = len(kinds)
        self.pieces = np.ascontiguousarray(pieces, dtype=np.float64).reshape(-1, 2, 2)
        counts = np.bincount(owner, minlength=n) if len(owner) else np.zeros(n, np.int64)
        self.end = np.cumsum(counts).astype(np.int64)
        self.start = (self.end - counts).astype(np.int64)
        self.kinds = np.ascontiguousarray(kinds, dtype=np.int8)
        box = np.full((n, 4), np.nan)
        has = counts > 0
        if has.any():  # an item's pieces are rows start..end: one reduction per run of rows
            (ax, ay), (bx, by) = self.pieces[:, 0].T, self.pieces[:, 1].T
            first = self.start[has]
            box[has, 0] = np.minimum.reduceat(np.minimum(ax, bx), first)
            box[has, 1] = np.minimum.reduceat(np.minimum(ay, by), first)
            box[has, 2] = np.maximum.reduceat(np.maximum(ax, bx), first)
            box[has, 3] = np.maximum.reduceat(np.maximum(ay, by), first)
        self.box = box
        has = ~np.isnan(box[:, 0])
        if has.any():
            lo = box[has, :2].min(axis=0)
            hi = box[has, 2:].max(axis=0)
        else:
            lo = hi = np.zeros(2)
        span = np.maximum(hi - lo, 1.0)
        # About two items per cell on average, never finer than 0.1 mm nor coarser than the
        # board in 64 cells a side.
        cell = max(math.sqrt(span[0] * span[1] / max(int(has.sum()), 1)) * 1.4, 100_000.0,
                   float(span.max()) / 64)
        self.origin = lo.astype(np.float64)
        self.cell = float(cell)
        self.shape = (int(span[0] // cell) + 1, int(span[1] // cell) + 1)
        self.first, self.items = _grid(self.box, self.origin, self.cell, self.shape[0],
                                       self.shape[1])
        # Per entry of the cells (one item of one cell), the item's box and, per `need`
        # (`_entries`), its reach: the boxes' test reads them in the cells' order.
        self.entry_box = np.ascontiguousarray(self.box[self.items])
        self._reach: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def judge(self, segments: np.ndarray, need: np.ndarray, max_need: float) -> np.ndarray:
        """Per segment (k, 2, 2): 0 clear, 1 violating, 2 unsure (see the module doc);
        `need` per item, -inf for items that are no obstacle."""
        segs = np.ascontiguousarray(segments, dtype=np.float64).reshape(-1, 2, 2)
        need, reach = self._entries(need)
        return _judge(segs, self.pieces, self.start, self.end, self.kinds, self.box, need,
                      float(max_need), self.origin, self.cell, self.shape[0], self.shape[1],
                      self.first, self.items, MARGIN, self.entry_box, reach)

    def pairs(self, segments: np.ndarray, need: np.ndarray, max_need: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(segment, item, status) for every pair that is violating (1) or unsure (2)."""
        segs = np.ascontiguousarray(segments, dtype=np.float64).reshape(-1, 2, 2)
        need, reach = self._entries(need)
        return _pairs(segs, self.pieces, self.start, self.end, self.kinds, self.box, need,
                      float(max_need), self.origin, self.cell, self.shape[0], self.shape[1],
                      self.first, self.items, MARGIN, self.entry_box, reach)

    def _entries(self, need: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`need` as float64 and each cell entry's reach under it (`need + MARGIN`, as
        `_pair_status` works it out), kept per `need` array (a set of rules asks many times;
        the array is held, so its id is not reused)."""
        kept = self._reach.get(id(need))
        if kept is None or kept[0] is not need:
            if len(self._reach) >= 16:
                self._reach.clear()
            values = np.ascontiguousarray(need, dtype=np.float64)
            kept = (need, values, np.ascontiguousarray(values[self.items] + MARGIN))
            self._reach[id(need)] = kept
        return kept[1], kept[2]


@_jit
def _cell_span(lo, hi, origin, cell, n):
    """The cells [first, last] that the interval [lo, hi] covers on one axis, clamped to the
    grid's n cells."""
    first = min(max(int((lo - origin) // cell), 0), n - 1)
    last = min(max(int((hi - origin) // cell), 0), n - 1)
    return first, last


@_jit
def _grid(box, origin, cell, nx, ny):
    counts = np.zeros(nx * ny + 1, np.int64)
    n = box.shape[0]
    for i in range(n):
        if box[i, 0] != box[i, 0]:  # nan: an item without pieces
            continue
        x0, x1 = _cell_span(box[i, 0], box[i, 2], origin[0], cell, nx)
        y0, y1 = _cell_span(box[i, 1], box[i, 3], origin[1], cell, ny)
        for gx in range(x0, x1 + 1):
            for gy in range(y0, y1 + 1):
                counts[gx * ny + gy + 1] += 1
    first = np.cumsum(counts)
    fill = first[:-1].copy()
    items = np.empty(first[-1], np.int64)
    for i in range(n):
        if box[i, 0] != box[i, 0]:
            continue
        x0, x1 = _cell_span(box[i, 0], box[i, 2], origin[0], cell, nx)
        y0, y1 = _cell_span(box[i, 1], box[i, 3], origin[1], cell, ny)
        for gx in range(x0, x1 + 1):
            for gy in range(y0, y1 + 1):
                c = gx * ny + gy
                items[fill[c]] = i
                fill[c] += 1
    return first, items


@_jit
def _point_segment(px, py, ax, ay, bx, by):
    dx = bx - ax
    dy = by - ay
    length2 = dx * dx + dy * dy
    if length2 <= 0.0:
        ex = px - ax
        ey = py - ay
        return math.sqrt(ex * ex + ey * ey)
    t = ((px - ax) * dx + (py - ay) * dy) / length2
    if t < 0.0:
        t = 0.0
    elif t > 1.0:
        t = 1.0
    ex = ax + t * dx - px
    ey = ay + t * dy - py
    return math.sqrt(ex * ex + ey * ey)


@_jit
def _segment_segment(ax, ay, bx, by, cx, cy, dx, dy):
    o1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    o2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    o3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    o4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    if ((o1 > 0.0 and o2 < 0.0) or (o1 < 0.0 and o2 > 0.0)) and \
            ((o3 > 0.0 and o4 < 0.0) or (o3 < 0.0 and o4 > 0.0)):
        return 0.0
    return min(_point_segment(ax, ay, cx, cy, dx, dy), _point_segment(bx, by, cx, cy, dx, dy),
               _point_segment(cx, cy, ax, ay, bx, by), _point_segment(dx, dy, ax, ay, bx, by))


@_jit
def _inside(px, py, pieces, start, end):
    """Even-odd test of a point against an area core's ring pieces."""
    inside = False
    for j in range(start, end):
        x1 = pieces[j, 0, 0]
        y1 = pieces[j, 0, 1]
        x2 = pieces[j, 1, 0]
        y2 = pieces[j, 1, 1]
        if (y1 > py) != (y2 > py):
            if px < x1 + (py - y1) * (x2 - x1) / (y2 - y1):
                inside = not inside
    return inside


@_jit
def _box_off_line(ax, ay, bx, by, x0, y0, x1, y1, reach):
    """Whether the box [x0, x1] x [y0, y1] lies wholly on one side of the line through a-b,
    at least `reach` from it (then it is at least that far from the segment, and from
    anything inside the box): a pair the boxes' test passes beside a long diagonal segment."""
    dx = bx - ax
    dy = by - ay
    length = math.sqrt(dx * dx + dy * dy)
    if length <= 0.0:
        return False
    nx = -dy / length
    ny = dx / length
    c = nx * ax + ny * ay
    lo = np.inf
    hi = -np.inf
    for px in (x0, x1):
        for py in (y0, y1):
            v = nx * px + ny * py - c
            lo = min(lo, v)
            hi = max(hi, v)
    return lo >= reach or hi <= -reach


@_jit
def _apart(boxes, reach, m, lox, loy, hix, hiy):
    """Whether box m lies farther than `reach` from the segment's box on one axis (`reach`
    -inf: an item that is no obstacle, always apart; a box of NaNs, never)."""
    return (boxes[m, 0] - hix >= reach or lox - boxes[m, 2] >= reach or
            boxes[m, 1] - hiy >= reach or loy - boxes[m, 3] >= reach)


@_jit
def _pair_status(i, ax, ay, bx, by, lox, loy, hix, hiy, pieces, start, end, kinds, box, need,
                 margin):
    """0 clear, 1 violating, 2 unsure for the segment a-b and item i."""
    limit = need[i]
    if limit == -np.inf:
        return 0
    reach = limit + margin  # boxes apart by more than the allowed distance
    if _apart(box, reach, i, lox, loy, hix, hiy):
        return 0
    if end[i] - start[i] > 2 and _box_off_line(ax, ay, bx, by, box[i, 0], box[i, 1],
                                               box[i, 2], box[i, 3], reach):
        return 0
    if kinds[i] == 2:
        return 2
    d = np.inf
    if kinds[i] == 1 and (_inside(ax, ay, pieces, start[i], end[i]) or
                          _inside(bx, by, pieces, start[i], end[i])):
        d = 0.0
    else:
        for j in range(start[i], end[i]):
            e = _segment_segment(ax, ay, bx, by, pieces[j, 0, 0], pieces[j, 0, 1],
                                 pieces[j, 1, 0], pieces[j, 1, 1])
            if e < d:
                d = e
            if d < limit - margin:
                return 1
    if d < limit - margin:
        return 1
    if d < limit + margin:
        return 2
    return 0


@_jit
def _band(a_major, a_minor, b_major, b_minor, c0, c1, grow):
    """The minor-axis range of the segment over the major-axis span [c0, c1], widened by
    grow; empty (lo > hi) where the segment does not come within grow of the span."""
    lo_major = min(a_major, b_major)
    hi_major = max(a_major, b_major)
    m0 = max(c0 - grow, lo_major)
    m1 = min(c1 + grow, hi_major)
    if m0 > m1:
        return 1.0, 0.0
    if hi_major > lo_major:
        slope = (b_minor - a_minor) / (b_major - a_major)
        v0 = a_minor + (m0 - a_major) * slope
        v1 = a_minor + (m1 - a_major) * slope
    else:
        v0 = a_minor
        v1 = b_minor
    return min(v0, v1) - grow, max(v0, v1) + grow


@_jit
def _judge(segs, pieces, start, end, kinds, box, need, max_need, origin, cell, nx, ny, first,
           items, margin, entry_box, entry_reach):
    """Per segment: the items of the cells its box (widened by the largest allowed distance)
    covers, until a violating one (see the module doc). Each cell entry's box is tested
    first, from the entries' own arrays (`_apart`: `_pair_status`'s first test, so the same
    statuses); only an item it keeps is looked up."""
    k = segs.shape[0]
    out = np.zeros(k, np.int8)
    stamp = np.full(box.shape[0], -1, np.int64)
    grow = max_need + 2 * margin
    for s in range(k):
        ax = segs[s, 0, 0]
        ay = segs[s, 0, 1]
        bx = segs[s, 1, 0]
        by = segs[s, 1, 1]
        lox = min(ax, bx)
        hix = max(ax, bx)
        loy = min(ay, by)
        hiy = max(ay, by)
        x0, x1 = _cell_span(lox - grow, hix + grow, origin[0], cell, nx)
        y0, y1 = _cell_span(loy - grow, hiy + grow, origin[1], cell, ny)
        status = 0
        for gx in range(x0, x1 + 1):
            for gy in range(y0, y1 + 1):
                c = gx * ny + gy
                for m in range(first[c], first[c + 1]):
                    if _apart(entry_box, entry_reach[m], m, lox, loy, hix, hiy):
                        continue
                    i = items[m]
                    if stamp[i] == s:
                        continue
                    stamp[i] = s
                    got = _pair_status(i, ax, ay, bx, by, lox, loy, hix, hiy, pieces, start,
                                       end, kinds, box, need, margin)
                    if got == 1:
                        status = 1
                        break
                    if got == 2:
                        status = 2
                if status == 1:
                    break
            if status == 1:
                break
        out[s] = status
    return out


@_jit
def _pairs(segs, pieces, start, end, kinds, box, need, max_need, origin, cell, nx, ny, first,
           items, margin, entry_box, entry_reach):
    """Every (segment, item) pair that is violating (1) or unsure (2), in segment order (the
    entries' boxes tested first, as in `_judge`)."""
    k = segs.shape[0]
    size = 16
    seg_out = np.empty(size, np.int64)
    item_out = np.empty(size, np.int64)
    status_out = np.empty(size, np.int8)
    count = 0
    stamp = np.full(box.shape[0], -1, np.int64)
    grow = max_need + 2 * margin
    for s in range(k):
        ax = segs[s, 0, 0]
        ay = segs[s, 0, 1]
        bx = segs[s, 1, 0]
        by = segs[s, 1, 1]
        lox = min(ax, bx)
        hix = max(ax, bx)
        loy = min(ay, by)
        hiy = max(ay, by)
        x0, x1 = _cell_span(lox - grow, hix + grow, origin[0], cell, nx)
        y0, y1 = _cell_span(loy - grow, hiy + grow, origin[1], cell, ny)
        for gx in range(x0, x1 + 1):
            for gy in range(y0, y1 + 1):
                c = gx * ny + gy
                for m in range(first[c], first[c + 1]):
                    if _apart(entry_box, entry_reach[m], m, lox, loy, hix, hiy):
                        continue
                    i = items[m]
                    if stamp[i] == s:
                        continue
                    stamp[i] = s
                    got = _pair_status(i, ax, ay, bx, by, lox, loy, hix, hiy, pieces, start,
                                       end, kinds, box, need, margin)
                    if got == 0:
                        continue
                    if count == size:
                        size *= 2
                        seg_out = np.concatenate((seg_out, np.empty(size - count, np.int64)))
                        item_out = np.concatenate((item_out, np.empty(size - count, np.int64)))
                        status_out = np.concatenate((status_out,
                                                     np.empty(size - count, np.int8)))
                    seg_out[count] = s
                    item_out[count] = i
                    status_out[count] = got
                    count += 1
    return seg_out[:count], item_out[:count], status_out[:count]


class CapsuleGrid:
    """The ray screen's capsules (`pcbdata.router.ray_screen.CapsuleScreen.table`: ax, ay, r,
    span, ux, uy per row) in a uniform grid of their boxes, for `entries`."""

    def __init__(self, table: np.ndarray, low: np.ndarray, high: np.ndarray):
        self.table = np.ascontiguousarray(table, dtype=np.float64)
        box = np.ascontiguousarray(np.column_stack([low, high]), dtype=np.float64)
        lo, hi = box[:, :2].min(axis=0), box[:, 2:].max(axis=0)
        span = np.maximum(hi - lo, 1.0)
        cell = max(math.sqrt(span[0] * span[1] / max(len(box), 1)) * 1.4, 100_000.0,
                   float(span.max()) / 256)
        self.origin, self.cell = lo.astype(np.float64), float(cell)
        self.shape = (int(span[0] // cell) + 1, int(span[1] // cell) + 1)
        self.first, self.items = _grid(box, self.origin, self.cell, *self.shape)

    def entries(self, points: np.ndarray, directions: np.ndarray, length: float) -> np.ndarray:
        return _ray_entries(np.ascontiguousarray(points, dtype=np.float64),
                            np.ascontiguousarray(directions, dtype=np.float64), float(length),
                            self.table, self.origin, self.cell, self.shape[0], self.shape[1],
                            self.first, self.items)


@_jit
def _disc_entry_1(wx, wy, dx, dy, r):
    half_b = dx * wx + dy * wy
    disc = half_b * half_b - (wx * wx + wy * wy - r * r)
    t = -half_b - math.sqrt(max(disc, 0.0))
    if disc >= 0.0 and t >= 0.0:
        return t
    return np.inf


@_jit
def _capsule_entry(px, py, dx, dy, row):
    """`ray_screen.CapsuleScreen._entry` for one ray and one capsule."""
    ax = row[0]
    ay = row[1]
    r = row[2]
    span = row[3]
    ux = row[4]
    uy = row[5]
    wx = px - ax
    wy = py - ay
    t = min(_disc_entry_1(wx, wy, dx, dy, r),
            _disc_entry_1(wx - span * ux, wy - span * uy, dx, dy, r))
    offset = ux * wy - uy * wx
    approach = ux * dy - uy * dx
    ahead = ux * wx + uy * wy
    if span > 0.0 and approach != 0.0:
        sign = 1.0 if approach > 0.0 else -1.0
        side = (-sign * r - offset) / approach
        foot = ahead + side * (ux * dx + uy * dy)
        if side >= 0.0 and foot >= 0.0 and foot <= span:
            t = min(t, side)
    beside = min(max(ahead, 0.0), span)
    ex = wx - beside * ux
    ey = wy - beside * uy
    if math.sqrt(ex * ex + ey * ey) <= r:
        return 0.0
    return t


@_jit
def _ray_entries(points, directions, length, table, origin, cell, nx, ny, first, items):
    """Per ray, the nearest capsule entry within `length` (inf if none): the cells along the
    ray from its start, stopping once an entry lies before the cells still to come."""
    k = points.shape[0]
    out = np.full(k, np.inf)
    stamp = np.full(table.shape[0], -1, np.int64)
    for s in range(k):
        px = points[s, 0]
        py = points[s, 1]
        dx = directions[s, 0]
        dy = directions[s, 1]
        qx = px + dx * length
        qy = py + dy * length
        x_major = abs(dx) >= abs(dy)
        if x_major:
            n_major, n_minor = nx, ny
            o_major, o_minor = origin[0], origin[1]
            a_mj, a_mn, b_mj, b_mn, d_mj = px, py, qx, qy, dx
        else:
            n_major, n_minor = ny, nx
            o_major, o_minor = origin[1], origin[0]
            a_mj, a_mn, b_mj, b_mn, d_mj = py, px, qy, qx, dy
        g0, g1 = _cell_span(min(a_mj, b_mj), max(a_mj, b_mj), o_major, cell, n_major)
        step = 1 if a_mj <= b_mj else -1
        first_g, last_g = (g0, g1) if step == 1 else (g1, g0)
        best = np.inf
        g = first_g
        while True:
            c0 = o_major + g * cell
            lo, hi = _band(a_mj, a_mn, b_mj, b_mn, c0, c0 + cell, 0.0)
            if lo <= hi:
                h0, h1 = _cell_span(lo, hi, o_minor, cell, n_minor)
                for h in range(h0, h1 + 1):
                    c = g * ny + h if x_major else h * ny + g
                    for m in range(first[c], first[c + 1]):
                        i = items[m]
                        if stamp[i] == s:
                            continue
                        stamp[i] = s
                        t = _capsule_entry(px, py, dx, dy, table[i])
                        if t < best:
                            best = t
            if g == last_g:
                break
            # the ray's parameter where it leaves this column (inside the grid)
            if d_mj != 0.0 and g != first_g:
                edge = c0 + cell if step == 1 else c0
                if best <= (edge - a_mj) / d_mj:
                    break
            g += step
        out[s] = best if best <= length else np.inf
    return out

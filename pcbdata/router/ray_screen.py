"""How far a ray runs before it enters a keep-out: the walkaround search's cheap screen.

A keep-out here is the set of points within a radius of an obstacle's core. Every core is cut
into straight pieces (a polygon's rings, a line's segments, a point as a zero-length piece), so a
keep-out is a union of capsules (a piece widened by the radius) and the entry of a ray into it
is the nearest entry into one of its capsules, worked out in closed form for whole batches of
(ray, capsule) pairs. That is exact where shapely's buffer-and-intersect only approximates the
round ends with polygons, and costs no geometry object per pair.

A ray that starts inside a polygonal core but farther than the radius from its boundary meets
the keep-out only where it comes near the boundary again: the bound is then longer than the
truth, never shorter, which is all the screen needs (it only ever rules out links longer than
a bound).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import shapely

from pcbdata.router import clearance_kernel
from pcbdata.router.clearance_kernel import CapsuleGrid


def core_pieces(core: shapely.Geometry) -> np.ndarray:
    """(k, 2, 2) float: the straight pieces of a core's boundary (a point: one zero-length
    piece; a line: its segments; a polygon: the segments of its rings)."""
    pieces: list[np.ndarray] = []
    for part in shapely.get_parts(core):
        if isinstance(part, shapely.Point):
            xy = shapely.get_coordinates(part)
            pieces.append(np.stack([xy, xy], axis=1))
        elif isinstance(part, shapely.LineString):
            pieces.append(_segments(shapely.get_coordinates(part)))
        elif isinstance(part, shapely.Polygon):
            pieces.extend(_segments(shapely.get_coordinates(ring))
                          for ring in shapely.get_rings(part))
        elif not part.is_empty:  # a nested collection (make_valid can give one)
            pieces.append(core_pieces(part))
    if not pieces:
        return np.empty((0, 2, 2))
    return np.concatenate(pieces).astype(float)


def _segments(coords: np.ndarray) -> np.ndarray:
    if len(coords) == 1:
        return np.stack([coords, coords], axis=1)
    return np.stack([coords[:-1], coords[1:]], axis=1)


class CapsuleScreen:
    """Capsules (piece, radius) in an R-tree of their bounding boxes."""

    def __init__(self, pieces: np.ndarray, radius: np.ndarray):
        start, end = pieces[:, 0], pieces[:, 1]
        e = end - start
        span = np.hypot(e[:, 0], e[:, 1])
        # Unit vector along each piece (zero for a zero-length piece).
        along = np.divide(e, span[:, None], out=np.zeros_like(e), where=span[:, None] > 0)
        # One row per capsule, gathered once per batch: ax, ay, r, span, ux, uy.
        self.table = np.column_stack([start, radius, span, along])
        low = np.minimum(start, end) - radius[:, None]
        high = np.maximum(start, end) + radius[:, None]
        self._low, self._high = low, high
        self._grid: CapsuleGrid | None = None

    def __len__(self) -> int:
        return len(self.table)

    @cached_property
    def tree(self) -> shapely.STRtree:
        """The capsules' boxes in an R-tree, queried by the rays' boxes in the reference form
        (an exact predicate costs more than the closed-form test that follows); built when
        that form first runs."""
        low, high = self._low, self._high
        return shapely.STRtree(shapely.box(low[:, 0], low[:, 1], high[:, 0], high[:, 1]))

    def entries(self, points: np.ndarray, directions: np.ndarray, length: float) -> np.ndarray:
        """Per ray (point, unit direction), the distance along it to the first capsule it
        enters within `length`; inf if it enters none that soon (0 if it starts inside)."""
        out = np.full(len(points), np.inf)
        if not len(self) or not len(points):
            return out
        if clearance_kernel.enabled():  # compiled: the cells along each ray, nearest first
            if self._grid is None:
                self._grid = CapsuleGrid(self.table, self._low, self._high)
            return self._grid.entries(points, directions, length)
        ends = points + directions * length
        rays = shapely.linestrings(np.stack([points, ends], axis=1))
        ray, capsule = self.tree.query(rays)
        if len(ray):
            t = self._entry(points[ray], directions[ray], capsule)
            t[t > length] = np.inf
            np.minimum.at(out, ray, t)
        return out

    def _entry(self, p: np.ndarray, d: np.ndarray, capsule: np.ndarray) -> np.ndarray:
        """Entry distance of each ray p + t d (t >= 0) into its capsule; inf if it misses.
        Written on columns: these batches are small and many, so fewer array operations
        matter more than fewer lines."""
        ax, ay, r, span, ux, uy = self.table[capsule].T
        dx, dy = d[:, 0], d[:, 1]
        wx, wy = p[:, 0] - ax, p[:, 1] - ay
        t = np.minimum(_disc_entry(wx, wy, dx, dy, r),
                       _disc_entry(wx - span * ux, wy - span * uy, dx, dy, r))
        offset, approach = ux * wy - uy * wx, ux * dy - uy * dx  # across the piece
        ahead = ux * wx + uy * wy  # along it
        # The side line the ray crosses into the band |offset| <= r.
        crossing = (span > 0) & (approach != 0)
        side = np.divide(-np.sign(approach) * r - offset, approach,
                         out=np.zeros(len(p)), where=crossing)
        foot = ahead + side * (ux * dx + uy * dy)
        on_side = crossing & (side >= 0) & (foot >= 0) & (foot <= span)
        t = np.where(on_side, np.minimum(t, side), t)
        # A start inside the capsule: its distance to the piece is within the radius.
        beside = np.clip(ahead, 0.0, span)
        inside = np.hypot(wx - beside * ux, wy - beside * uy) <= r
        return np.where(inside, 0.0, t)


def _disc_entry(wx: np.ndarray, wy: np.ndarray, dx: np.ndarray, dy: np.ndarray,
                r: np.ndarray) -> np.ndarray:
    """Where each ray (start at w from the disc's centre, unit direction d) enters the disc of
    radius r from outside; inf if it does not."""
    half_b = dx * wx + dy * wy
    disc = half_b * half_b - (wx * wx + wy * wy - r * r)
    t = -half_b - np.sqrt(np.maximum(disc, 0.0))
    return np.where((disc >= 0) & (t >= 0), t, np.inf)

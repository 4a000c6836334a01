"""The seven per-board statistics of SPEC section 2b, read from a `.kicad_pcb` file's text.

Used to compare synthetic boards with the real D3 tiers (`bench/bench_realism.py`,
docs/realism.md). No KiCad: the file is tokenised here and the Edge.Cuts outline is
polygonised with shapely, so a thousand boards take seconds and any KiCad 6 or later board
file (bare board, reference) can be measured. A legacy file (many of PCBench's
`processed.kicad_pcb`) is measured on KiCad 9's save of it, as D3 ships it: its arcs are
written by centre and angle, which this reader leaves out of the outline (read as text, 29
of D3-A's 100 boards measure another density; `pcbdata.realism.external`).

Definitions (all lengths in mm):
- **terminal pad**: a pad on a net that has at least two pads on the board (a pad alone on its
  net, or on no net, needs no routing). This is how PCBench's `final.json` lists nets, which
  is where D3's `characteristics.csv` counts come from;
- **nets**: nets with at least two pads; **pads**: terminal pads;
- **components**: footprints on the board (all of them, as `characteristics.csv`);
- **pads per net**: the pad count of each such net (a list per board);
- **layers**: copper layers declared in the board's layer table;
- **pad density**: terminal pads per cm2 of the Edge.Cuts outline's area (holes cut out);
- **pad pitch**: per footprint with two or more distinct pad centres, the smallest distance
  between two of them (NPTH holes are not pads); per board the median over such footprints.
"""
from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from pcbdata.core.copper_geometry import arc_polyline
from pcbdata.core.copper_text import SEXPR_TOKEN

if TYPE_CHECKING:
    from numpy.typing import NDArray

#: The seven statistics, in the order of tables and reports.
STATISTICS = ("nets", "pads", "components", "pads_per_net", "layers", "pad_density",
              "pad_pitch")
#: KS-test pools: one value per board, except pads per net (every net of every board).
PER_NET = "pads_per_net"

#: Edge.Cuts endpoints closer than this are one point (drawn outlines rarely meet exactly);
#: the wider tolerance is tried only when nothing closes with the narrow one (outlines
#: traced from a bitmap, with gaps of a tenth of a millimetre).
SNAP_MM = (0.01, 0.2)
#: Farthest an outline's polyline strays from its arcs and circles.
ARC_TOLERANCE_MM = 0.005
#: Pitches are rounded to KiCad's resolution (1 nm): differences of file coordinates carry
#: float noise (10.16 - 7.62 is 2.5400000000000009), which would split equal pitches of two
#: boards into distinct values and count as a KS distance.
PITCH_DECIMALS = 6

Sexpr = list  # nested lists of str atoms (quoted strings keep no quotes)


def parse_sexpr(text: str) -> Sexpr:
    """The first expression of `text` as nested lists of atoms (strings unquoted)."""
    stack: list[list] = [[]]
    for token in SEXPR_TOKEN.findall(text):
        if token == "(":
            stack.append([])
        elif token == ")":
            done = stack.pop()
            if not stack:
                raise ValueError("malformed s-expression: a ')' closes nothing")
            stack[-1].append(done)
            if len(stack) == 1:
                return done
        elif token.startswith('"'):
            stack[-1].append(_unquote(token))
        else:
            stack[-1].append(token)
    raise ValueError("malformed s-expression: not closed")


def _unquote(token: str) -> str:
    return re.sub(r"\\(.)", r"\1", token[1:-1])


def children(node: Sexpr, head: str) -> list[Sexpr]:
    return [c for c in node[1:] if isinstance(c, list) and c and c[0] == head]


def child(node: Sexpr, head: str) -> Sexpr | None:
    found = children(node, head)
    return found[-1] if found else None


def _point(node: Sexpr | None) -> tuple[float, float] | None:
    if node is None or len(node) < 3:
        return None
    return float(node[1]), float(node[2])


@dataclass(frozen=True)
class BoardStatistics:
    nets: int
    pads: int
    components: int
    layers: int
    pads_per_net: tuple[int, ...]
    #: Edge.Cuts outline area in mm2; None when the outline closes no region.
    outline_area_mm2: float | None
    #: Per multi-pad footprint, its smallest pad centre distance (mm).
    footprint_pitches: tuple[float, ...] = field(default=())

    @property
    def pad_density(self) -> float | None:
        if not self.outline_area_mm2:
            return None
        return self.pads / (self.outline_area_mm2 / 100.0)

    @property
    def pad_pitch(self) -> float | None:
        if not self.footprint_pitches:
            return None
        return round(float(_median(self.footprint_pitches)), PITCH_DECIMALS)

    def values(self) -> dict[str, list[float]]:
        """Each statistic's contribution to a sample: one value, none (undefined), or, for
        pads per net, one per net."""
        scalar = {"nets": self.nets, "pads": self.pads, "components": self.components,
                  "layers": self.layers, "pad_density": self.pad_density,
                  "pad_pitch": self.pad_pitch}
        out = {name: ([] if value is None else [float(value)]) for name, value in scalar.items()}
        out[PER_NET] = [float(n) for n in self.pads_per_net]
        return {name: out[name] for name in STATISTICS}


def _median(values: Sequence[float]) -> float:
    ordered = sorted(values)
    mid = len(ordered) // 2
    return ordered[mid] if len(ordered) % 2 else (ordered[mid - 1] + ordered[mid]) / 2


def board_statistics(path: str | Path) -> BoardStatistics:
    """The statistics of one board file (raises ValueError on a file that is not a board)."""
    return statistics_of(parse_sexpr(Path(path).read_text(encoding="utf-8", errors="replace")))


def statistics_of(board: Sexpr) -> BoardStatistics:
    if not board or board[0] != "kicad_pcb":
        raise ValueError("not a KiCad board (no kicad_pcb expression)")
    footprints = children(board, "footprint") + children(board, "module")
    pad_nets = [_pad_net(pad) for fp in footprints for pad in _copper_pads(fp)]
    counts: dict[str, int] = {}
    for net in pad_nets:
        if net:
            counts[net] = counts.get(net, 0) + 1
    per_net = tuple(sorted(n for n in counts.values() if n >= 2))
    return BoardStatistics(
        nets=len(per_net), pads=sum(per_net), components=len(footprints),
        layers=_copper_layer_count(board), pads_per_net=per_net,
        outline_area_mm2=outline_area(board),
        footprint_pitches=tuple(p for p in map(_footprint_pitch, footprints) if p is not None))


def _copper_pads(footprint: Sexpr) -> list[Sexpr]:
    """Pads that carry copper (an NPTH hole is a mechanical feature, not a pad to route; a
    paste-only aperture drawn as a pad is no terminal)."""
    return [p for p in children(footprint, "pad")
            if len(p) > 2 and p[2] != "np_thru_hole" and _has_copper(p)]


def _has_copper(pad: Sexpr) -> bool:
    """A pad on a copper layer (paste or mask apertures drawn as pads are not)."""
    layers = child(pad, "layers")
    return layers is None or any(str(name).endswith(".Cu") for name in layers[1:])


def _pad_net(pad: Sexpr) -> str | None:
    """The pad's net name (KiCad 9 writes `(net 3 "GND")`, KiCad 10 `(net "GND")`)."""
    net = child(pad, "net")
    if net is None or len(net) < 2:
        return None
    name = net[-1] if len(net) > 2 else net[1]
    return name or None


def _copper_layer_count(board: Sexpr) -> int:
    table = child(board, "layers")
    if table is None:
        return 0
    return sum(1 for entry in table[1:]
               if isinstance(entry, list) and len(entry) > 1 and str(entry[1]).endswith(".Cu"))


def _footprint_pitch(footprint: Sexpr) -> float | None:
    """The smallest distance between two distinct pad centres; rotation and side do not change
    distances, so the footprint's own frame serves."""
    import numpy as np

    centres = {p for p in (_point(child(pad, "at")) for pad in _copper_pads(footprint)) if p}
    if len(centres) < 2:
        return None
    xy = np.array(sorted(centres))
    gaps = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    gaps[np.diag_indices(len(xy))] = np.inf
    return round(float(gaps.min()), PITCH_DECIMALS)


# --- the outline -------------------------------------------------------------------------

def outline_area(board: Sexpr) -> float | None:
    """Area (mm2) of the region the Edge.Cuts drawings enclose, holes (nested closed
    outlines) cut out by even-odd nesting; None if nothing closes."""
    paths = edge_paths(board)
    for tolerance in SNAP_MM:
        area = _enclosed_area(paths, tolerance)
        if area:
            return area
    return None


def _enclosed_area(paths: list[list[tuple[float, float]]], tolerance: float) -> float | None:
    import shapely
    from shapely.geometry import LineString, Point, Polygon
    from shapely.ops import polygonize, unary_union

    snap = _Snapper(tolerance)
    paths = [_snap_path(p, snap) for p in paths]
    lines = [LineString(p) for p in paths if len(p) >= 2 and LineString(p).length > 0]
    if not lines:
        return None
    faces = [f for f in polygonize(unary_union(lines)) if f.area > 0]
    if not faces:
        return None
    shells = [Polygon(f.exterior) for f in faces]
    shapely.prepare(shells)
    area = 0.0
    for face in faces:
        inside: Point = face.representative_point()
        depth = sum(1 for s in shells if s.contains(inside)) - 1
        if depth % 2 == 0:
            area += face.area
    return area or None


class _Snapper:
    """Merges points closer than `tolerance` to the first one seen (grid cells of that size)."""

    def __init__(self, tolerance: float) -> None:
        self.tolerance = tolerance
        self.cells: dict[tuple[int, int], list[tuple[float, float]]] = {}

    def __call__(self, point: tuple[float, float]) -> tuple[float, float]:
        cx, cy = (int(math.floor(v / self.tolerance)) for v in point)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for seen in self.cells.get((cx + dx, cy + dy), ()):
                    if math.dist(seen, point) <= self.tolerance:
                        return seen
        self.cells.setdefault((cx, cy), []).append(point)
        return point


def _snap_path(path: list[tuple[float, float]], snap: _Snapper) -> list[tuple[float, float]]:
    """Snap the ends only: interior points of an arc are where they are."""
    if len(path) < 2:
        return path
    return [snap(path[0]), *path[1:-1], snap(path[-1])]


def edge_paths(board: Sexpr) -> list[list[tuple[float, float]]]:
    """Every Edge.Cuts drawing as a polyline in board coordinates, footprint drawings
    included (outlines often come inside a footprint)."""
    paths = [p for item in board[1:] if _on_edge(item) for p in _item_paths(item)]
    for fp in children(board, "footprint") + children(board, "module"):
        place = _placement(fp)
        for item in fp[1:]:
            if _on_edge(item):
                paths.extend([[place(pt) for pt in p] for p in _item_paths(item)])
    return paths


def _on_edge(item: object) -> bool:
    if not isinstance(item, list) or not item or not str(item[0]).startswith(("gr_", "fp_")):
        return False
    layer = child(item, "layer")
    return layer is not None and len(layer) > 1 and layer[1] == "Edge.Cuts"


def _placement(footprint: Sexpr):
    """Footprint frame to board coordinates (KiCad: y down, angles counter-clockwise on
    screen; child items are stored relative to the footprint, side flip already applied)."""
    at = child(footprint, "at")
    x0, y0 = _point(at) or (0.0, 0.0)
    angle = math.radians(float(at[3])) if at is not None and len(at) > 3 else 0.0
    c, s = math.cos(angle), math.sin(angle)

    def place(pt: tuple[float, float]) -> tuple[float, float]:
        return x0 + pt[0] * c + pt[1] * s, y0 - pt[0] * s + pt[1] * c
    return place


def _item_paths(item: Sexpr) -> list[list[tuple[float, float]]]:
    kind = str(item[0])[3:]
    start, end = _point(child(item, "start")), _point(child(item, "end"))
    if kind == "line" and start and end:
        return [[start, end]]
    if kind == "rect" and start and end:
        (x1, y1), (x2, y2) = start, end
        return [[(x1, y1), (x2, y1), (x2, y2), (x1, y2), (x1, y1)]]
    if kind == "circle":
        centre = _point(child(item, "center")) or start
        if centre and end:
            return [_circle(centre, math.dist(centre, end))]
    if kind == "arc" and start and end:
        mid = _point(child(item, "mid"))
        return [_arc(start, mid, end)] if mid else []
    if kind in ("poly", "curve"):
        return [_pts_path(child(item, "pts"), closed=kind == "poly")]
    return []


def _pts_path(pts: Sexpr | None, closed: bool) -> list[tuple[float, float]]:
    path: list[tuple[float, float]] = []
    for node in (pts or [])[1:]:
        if isinstance(node, list) and node and node[0] == "xy":
            path.append((float(node[1]), float(node[2])))
        elif isinstance(node, list) and node and node[0] == "arc":
            a, m, b = (_point(child(node, k)) for k in ("start", "mid", "end"))
            if a and m and b:
                path.extend(_arc(a, m, b))
    if closed and len(path) > 2 and path[0] != path[-1]:
        path.append(path[0])
    return path


def _circle(centre: tuple[float, float], radius: float) -> list[tuple[float, float]]:
    on = (centre[0] + radius, centre[1])
    return arc_polyline(on, (centre[0] - radius, centre[1]), on, ARC_TOLERANCE_MM)


def _arc(a: tuple[float, float], m: tuple[float, float],
         b: tuple[float, float]) -> list[tuple[float, float]]:
    return arc_polyline(a, m, b, ARC_TOLERANCE_MM)


# --- samples and distances ---------------------------------------------------------------

def pooled_samples(stats: Iterable[BoardStatistics]) -> dict[str, list[float]]:
    """Each statistic's sample over boards (pads per net: every net of every board)."""
    pooled: dict[str, list[float]] = {name: [] for name in STATISTICS}
    for one in stats:
        for name, values in one.values().items():
            pooled[name].extend(values)
    return pooled


#: Per-board shapes of a board's nets, reported beside the seven (not SPEC statistics): the
#: pooled pads per net cannot tell boards of all two-pad nets plus boards of large ones from
#: boards that are all alike.
NET_SHAPES = ("two_pad_net_share", "largest_net_share")


def net_shape_samples(stats: Iterable[BoardStatistics]) -> dict[str, list[float]]:
    """Per board with nets: the share of its nets that have two pads, and the share of its
    terminal pads on its largest net."""
    out: dict[str, list[float]] = {name: [] for name in NET_SHAPES}
    for one in stats:
        if one.pads_per_net:
            out["two_pad_net_share"].append(
                sum(1 for n in one.pads_per_net if n == 2) / len(one.pads_per_net))
            out["largest_net_share"].append(max(one.pads_per_net) / sum(one.pads_per_net))
    return out


def weighted_samples(stats: Sequence[BoardStatistics], weights: Sequence[float]
                     ) -> dict[str, tuple[list[float], list[float]]]:
    """Per statistic and net shape, (values, weights): every value carries its board's
    weight (each net of a board, for pads per net)."""
    out: dict[str, tuple[list[float], list[float]]] = {
        name: ([], []) for name in STATISTICS + NET_SHAPES}
    for one, weight in zip(stats, weights, strict=True):
        for sample in (one.values(), net_shape_samples([one])):
            for name, values in sample.items():
                out[name][0].extend(values)
                out[name][1].extend([weight] * len(values))
    return out


def ks_distance(a: Sequence[float] | NDArray, b: Sequence[float] | NDArray,
                a_weights: Sequence[float] | None = None,
                b_weights: Sequence[float] | None = None) -> float | None:
    """Two-sample Kolmogorov-Smirnov distance: the largest gap between the two empirical
    distribution functions (None if a sample is empty). With weights, a value's step in its
    sample's function is its share of the sample's weight."""
    import numpy as np

    if len(a) == 0 or len(b) == 0:
        return None
    if a_weights is not None or b_weights is not None:
        at = np.concatenate([np.asarray(a, dtype=float), np.asarray(b, dtype=float)])
        return float(np.max(np.abs(_weighted_cdf(a, a_weights, at)
                                   - _weighted_cdf(b, b_weights, at))))
    # Unweighted: the weighted path is a third slower, and `--noise` calls this ~10^5 times.
    xa, xb = np.sort(np.asarray(a, dtype=float)), np.sort(np.asarray(b, dtype=float))
    at = np.concatenate([xa, xb])
    fa = np.searchsorted(xa, at, side="right") / len(xa)
    fb = np.searchsorted(xb, at, side="right") / len(xb)
    return float(np.max(np.abs(fa - fb)))


def _weighted_cdf(values, weights, at):
    """The sample's distribution function at `at` (unit weights: count / size, exactly)."""
    import numpy as np

    x = np.asarray(values, dtype=float)
    w = np.ones_like(x) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != x.shape or np.any(w < 0) or not w.sum() > 0:
        raise ValueError("weights must be one non-negative number per value, not all 0")
    order = np.argsort(x, kind="stable")
    steps = np.concatenate([[0.0], np.cumsum(w[order])]) / w.sum()
    return steps[np.searchsorted(x[order], at, side="right")]


QUANTILES = (5, 10, 25, 50, 75, 90, 95)


def summary(values: Sequence[float]) -> dict:
    """Quantiles (numpy's linear interpolation), mean and count of a sample."""
    import numpy as np

    if len(values) == 0:
        return {"count": 0, "mean": None, "quantiles": {str(q): None for q in QUANTILES}}
    arr = np.asarray(values, dtype=float)
    return {"count": int(arr.size), "mean": round(float(arr.mean()), 6),
            "quantiles": {str(q): round(float(np.percentile(arr, q)), 6) for q in QUANTILES}}

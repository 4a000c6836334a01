"""Pictures for the dataset card: pad-count histograms (plain SVG written here) and board
previews: the task with its ratsnest next to the reference routing (`pcbdata.core.drawing`, from
records KiCad reads in workers, `pcbdata.kicad.board_records`), or beside a picture already drawn
(a D2R board beside a real board of its tier, `pcbdata.publish.real_boards`)."""
from __future__ import annotations

import base64
import math
from collections.abc import Sequence
from dataclasses import dataclass
from html import escape
from pathlib import Path

import numpy as np

from pcbdata.board_render import Picture, draw_picture, read_boards
from pcbdata.core.drawing import png_bytes, side_by_side
from pcbdata.kicad import KicadPool
from pcbdata.publish.layout import write_file
from pcbdata.sets.configs import D3_TIERS

# Colours of the D3 tiers, and of everything else.
_TIER_COLOURS = {D3_TIERS["A"]: "#4c78a8", D3_TIERS["B"]: "#f58518", D3_TIERS["C"]: "#54a24b"}
_BAR = "#4c78a8"


def _bins(values: list[int], log: bool) -> list[tuple[float, float]]:
    lo, hi = min(values), max(values)
    if hi == lo:
        return [(lo - 0.5, hi + 0.5)]
    if log:
        lo_l, hi_l = math.log10(max(lo, 1)), math.log10(hi + 1)
        n = max(8, min(40, int((hi_l - lo_l) * 12)))
        edges = [10 ** (lo_l + (hi_l - lo_l) * k / n) for k in range(n + 1)]
    else:
        span = hi - lo + 1
        width = max(1, math.ceil(span / 40))
        n = math.ceil(span / width)
        edges = [lo - 0.5 + width * k for k in range(n + 1)]
    return list(zip(edges, edges[1:]))


@dataclass(frozen=True)
class _Plot:
    """The histogram's frame: pixel geometry and the data ranges of both axes."""

    x_lo: float
    x_hi: float
    y_max: int
    log: bool
    width: int = 640
    height: int = 300
    left: int = 56
    right: int = 16
    top: int = 36
    bottom: int = 48

    @property
    def plot_w(self) -> int:
        return self.width - self.left - self.right

    @property
    def plot_h(self) -> int:
        return self.height - self.top - self.bottom

    def x_of(self, v: float) -> float:
        if self.log:
            return self.left + self.plot_w * (math.log10(max(v, 1e-9)) - math.log10(self.x_lo)) / (
                math.log10(self.x_hi) - math.log10(self.x_lo))
        return self.left + self.plot_w * (v - self.x_lo) / (self.x_hi - self.x_lo)

    def y_of(self, c: float) -> float:
        return self.top + self.plot_h * (1 - c / self.y_max)


def histogram_svg(series: dict[str, list[int]], title: str,
                  boundaries: Sequence[tuple[float, str]] = (),
                  log: bool | None = None) -> str:
    """A stacked histogram of pad counts, one colour per series (e.g. per D3 tier).

    `boundaries` are (x, label) vertical lines, e.g. the tier limits."""
    values = [v for vals in series.values() for v in vals] or [0]
    if log is None:
        log = max(values) > 200 and max(values) > 20 * max(1, min(values))
    # the axis spans the boundaries too, so that every tier limit is drawn
    bins = _bins(values + [round(x) for x, _ in boundaries], log)
    counts = _counts(series, bins)
    totals = [sum(counts[n][k] for n in series) for k in range(len(bins))]
    plot = _Plot(x_lo=bins[0][0], x_hi=bins[-1][1], y_max=max(totals) or 1, log=log)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{plot.width}" height="{plot.height}" '
           f'viewBox="0 0 {plot.width} {plot.height}" font-family="sans-serif" font-size="11">',
           f'<rect width="{plot.width}" height="{plot.height}" fill="white"/>',
           f'<text x="{plot.width / 2}" y="20" text-anchor="middle" font-size="14">'
           f'{escape(title)}</text>']
    out += _bars(plot, bins, counts)
    out += _axes(plot)
    out += _boundary_lines(plot, boundaries)
    if len(series) > 1:
        out += _legend(plot, series)
    out.append("</svg>")
    return "\n".join(out) + "\n"


def _counts(series: dict[str, list[int]], bins: list[tuple[float, float]]) -> dict[str, list[int]]:
    counts = {name: [0] * len(bins) for name in series}
    for name, vals in series.items():
        for v in vals:
            for k, (a, b) in enumerate(bins):
                if a <= v < b or (k == len(bins) - 1 and v == b):
                    counts[name][k] += 1
                    break
    return counts


def _bars(plot: _Plot, bins: list[tuple[float, float]], counts: dict[str, list[int]]) -> list[str]:
    out = []
    for k, (a, b) in enumerate(bins):
        base = 0
        for name, per_bin in counts.items():
            c = per_bin[k]
            if not c:
                continue
            x0, x1 = plot.x_of(a), plot.x_of(b)
            out.append(f'<rect x="{x0:.2f}" y="{plot.y_of(base + c):.2f}" '
                       f'width="{max(x1 - x0 - 1, 0.5):.2f}" '
                       f'height="{plot.y_of(base) - plot.y_of(base + c):.2f}" '
                       f'fill="{_TIER_COLOURS.get(name, _BAR)}">'
                       f'<title>{escape(name)}: {c} boards with {math.ceil(a)}-{math.floor(b)} '
                       f'pads</title></rect>')
            base += c
    return out


def _axes(plot: _Plot) -> list[str]:
    left, top, plot_w, plot_h = plot.left, plot.top, plot.plot_w, plot.plot_h
    out = [f'<line x1="{left}" y1="{top + plot_h}" x2="{left + plot_w}" y2="{top + plot_h}" '
           f'stroke="black"/>',
           f'<line x1="{left}" y1="{top}" x2="{left}" y2="{top + plot_h}" stroke="black"/>']
    for frac in (0, 0.5, 1):
        c = round(plot.y_max * frac)
        out.append(f'<text x="{left - 6}" y="{plot.y_of(c) + 4:.1f}" text-anchor="end">{c}</text>')
    if plot.log:
        ticks = [t for e in range(0, 6) for t in (10 ** e, 2 * 10 ** e, 5 * 10 ** e)
                 if plot.x_lo <= t <= plot.x_hi]
    else:
        step = max(1, math.ceil((plot.x_hi - plot.x_lo) / 8))
        ticks = list(range(math.ceil(plot.x_lo), math.floor(plot.x_hi) + 1, step))
    for t in ticks:
        out.append(f'<text x="{plot.x_of(t):.1f}" y="{top + plot_h + 16}" '
                   f'text-anchor="middle">{t}</text>')
    out.append(f'<text x="{left + plot_w / 2}" y="{plot.height - 10}" text-anchor="middle">'
               f'pads (terminal pads per board{", log scale" if plot.log else ""})</text>')
    out.append(f'<text x="14" y="{top + plot_h / 2}" text-anchor="middle" '
               f'transform="rotate(-90 14 {top + plot_h / 2})">boards</text>')
    return out


def _boundary_lines(plot: _Plot, boundaries: Sequence[tuple[float, str]]) -> list[str]:
    out = []
    for x, label in boundaries:
        if plot.x_lo <= x <= plot.x_hi:
            out.append(f'<line x1="{plot.x_of(x):.1f}" y1="{plot.top}" x2="{plot.x_of(x):.1f}" '
                       f'y2="{plot.top + plot.plot_h}" stroke="#d62728" stroke-dasharray="4 3"/>')
            out.append(f'<text x="{plot.x_of(x) + 3:.1f}" y="{plot.top + 10}" fill="#d62728">'
                       f'{escape(label)}</text>')
    return out


def _legend(plot: _Plot, series: dict[str, list[int]]) -> list[str]:
    out = []
    for k, name in enumerate(series):
        y = plot.top + 4 + 14 * k
        out.append(f'<rect x="{plot.left + plot.plot_w - 90}" y="{y}" width="10" height="10" '
                   f'fill="{_TIER_COLOURS.get(name, _BAR)}"/>')
        out.append(f'<text x="{plot.left + plot.plot_w - 76}" y="{y + 9}">{escape(name)} '
                   f'({len(series[name])})</text>')
    return out


def preview_svg(png: bytes, width: int, height: int, title: str) -> str:
    """An SVG page holding one PNG picture (the card's previews stay `.svg` files)."""
    data = base64.b64encode(png).decode("ascii")
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}"><title>{escape(title)}</title>'
            f'<image width="{width}" height="{height}" href="data:image/png;base64,{data}"/>'
            f'</svg>\n')


@dataclass(frozen=True)
class PreviewJob:
    """One card picture: `panels` (title, board file) drawn side by side into `out` (an SVG),
    then `beside`, a picture already drawn (a real board of the tier beside a D2R board)."""

    panels: list[tuple[str, Path]]
    out: Path
    beside: np.ndarray | None = None


class PreviewRenderer:
    """Draws board previews (`pcbdata.core.drawing`) from records that KiCad reads in worker
    processes (`pcbdata.kicad.board_records`), one pool per publication; workers start only
    when there is a preview to draw. Previews are illustrations, never required: a board that
    cannot be read gives a reason, not an error."""

    def __init__(self, workers: int = 2, timeout: float = 120.0):
        self._pool = KicadPool(workers=workers, task_timeout=timeout)

    def __enter__(self) -> PreviewRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self._pool.close()

    def render(self, jobs: list[PreviewJob]) -> list[str | None]:
        """Draws each job, its panels side by side (then its `beside` picture); returns, per
        job, None or the reason it could not."""
        paths = sorted({path for job in jobs for _, path in job.panels})
        records = read_boards(paths, self._pool)
        problems: list[str | None] = []
        for job in jobs:
            out_path = job.out
            drawn = draw_picture(Picture(out_path.stem, job.panels), records)
            if isinstance(drawn, str):
                problems.append(drawn)
                continue
            if job.beside is not None:
                drawn = side_by_side([drawn, job.beside])
            height, width = drawn.shape[:2]
            write_file(out_path, preview_svg(png_bytes(drawn), width, height, out_path.stem))
            problems.append(None)
        return problems


def pick_previews(boards: list[tuple[str, int]], count: int) -> list[str]:
    """`count` board ids spread over the pad-count range: smallest, median, largest, ..."""
    ordered = sorted(boards, key=lambda b: (b[1], b[0]))
    if count <= 0 or not ordered:
        return []
    if count == 1:
        return [ordered[len(ordered) // 2][0]]
    picks = []
    for k in range(count):
        board_id = ordered[round(k * (len(ordered) - 1) / (count - 1))][0]
        if board_id not in picks:
            picks.append(board_id)
    return picks

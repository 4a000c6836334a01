"""Pictures for the dataset card: pad-count histograms (plain SVG written here) and board
previews (`kicad-cli pcb export svg`, run in KiCad workers by `pcbdata.kicad.previews`)."""
from __future__ import annotations

import math
import re
from collections.abc import Sequence
from html import escape
from pathlib import Path

from pcbdata.configs import D3_TIERS
from pcbdata.kicad import KicadPool
from pcbdata.publish.layout import write_file

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


def histogram_svg(series: dict[str, list[int]], title: str,
                  boundaries: Sequence[tuple[float, str]] = (),
                  log: bool | None = None) -> str:
    """A stacked histogram of pad counts, one colour per series (e.g. per D3 tier).

    `boundaries` are (x, label) vertical lines, e.g. the tier limits."""
    values = [v for vals in series.values() for v in vals]
    if not values:
        values = [0]
    if log is None:
        log = max(values) > 200 and max(values) > 20 * max(1, min(values))
    # the axis spans the boundaries too, so that every tier limit is drawn
    bins = _bins(values + [round(x) for x, _ in boundaries], log)
    counts = {name: [0] * len(bins) for name in series}
    for name, vals in series.items():
        for v in vals:
            for k, (a, b) in enumerate(bins):
                if a <= v < b or (k == len(bins) - 1 and v == b):
                    counts[name][k] += 1
                    break
    totals = [sum(counts[n][k] for n in series) for k in range(len(bins))]
    width, height, left, right, top, bottom = 640, 300, 56, 16, 36, 48
    plot_w, plot_h = width - left - right, height - top - bottom
    x_lo, x_hi = bins[0][0], bins[-1][1]

    def x_of(v: float) -> float:
        if log:
            return left + plot_w * (math.log10(max(v, 1e-9)) - math.log10(x_lo)) / (
                math.log10(x_hi) - math.log10(x_lo))
        return left + plot_w * (v - x_lo) / (x_hi - x_lo)

    y_max = max(totals) or 1

    def y_of(c: float) -> float:
        return top + plot_h * (1 - c / y_max)

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">',
           f'<rect width="{width}" height="{height}" fill="white"/>',
           f'<text x="{width / 2}" y="20" text-anchor="middle" font-size="14">{escape(title)}</text>']
    for k, (a, b) in enumerate(bins):
        base = 0
        for name in series:
            c = counts[name][k]
            if not c:
                continue
            colour = _TIER_COLOURS.get(name, _BAR)
            x0, x1 = x_of(a), x_of(b)
            out.append(f'<rect x="{x0:.2f}" y="{y_of(base + c):.2f}" width="{max(x1 - x0 - 1, 0.5):.2f}" '
                       f'height="{y_of(base) - y_of(base + c):.2f}" fill="{colour}">'
                       f'<title>{escape(name)}: {c} boards with {math.ceil(a)}-{math.floor(b)} pads</title></rect>')
            base += c
    # axes and ticks
    out.append(f'<line x1="{left}" y1="{top + plot_h}" x2="{left + plot_w}" y2="{top + plot_h}" stroke="black"/>')
    out.append(f'<line x1="{left}" y1="{top}" x2="{left}" y2="{top + plot_h}" stroke="black"/>')
    for frac in (0, 0.5, 1):
        c = round(y_max * frac)
        out.append(f'<text x="{left - 6}" y="{y_of(c) + 4:.1f}" text-anchor="end">{c}</text>')
    if log:
        ticks = [t for e in range(0, 6) for t in (10 ** e, 2 * 10 ** e, 5 * 10 ** e) if x_lo <= t <= x_hi]
    else:
        step = max(1, math.ceil((x_hi - x_lo) / 8))
        ticks = list(range(math.ceil(x_lo), math.floor(x_hi) + 1, step))
    for t in ticks:
        out.append(f'<text x="{x_of(t):.1f}" y="{top + plot_h + 16}" text-anchor="middle">{t}</text>')
    out.append(f'<text x="{left + plot_w / 2}" y="{height - 10}" text-anchor="middle">'
               f'pads (terminal pads per board{", log scale" if log else ""})</text>')
    out.append(f'<text x="14" y="{top + plot_h / 2}" text-anchor="middle" '
               f'transform="rotate(-90 14 {top + plot_h / 2})">boards</text>')
    for x, label in boundaries:
        if x_lo <= x <= x_hi:
            out.append(f'<line x1="{x_of(x):.1f}" y1="{top}" x2="{x_of(x):.1f}" y2="{top + plot_h}" '
                       f'stroke="#d62728" stroke-dasharray="4 3"/>')
            out.append(f'<text x="{x_of(x) + 3:.1f}" y="{top + 10}" fill="#d62728">{escape(label)}</text>')
    if len(series) > 1:
        for k, name in enumerate(series):
            y = top + 4 + 14 * k
            out.append(f'<rect x="{left + plot_w - 90}" y="{y}" width="10" height="10" '
                       f'fill="{_TIER_COLOURS.get(name, _BAR)}"/>')
            out.append(f'<text x="{left + plot_w - 76}" y="{y + 9}">{escape(name)} ({len(series[name])})</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


class PreviewRenderer:
    """Renders board previews in KiCad worker processes, one pool per publication; workers
    start only when there is a preview to render. Previews are illustrations, never required:
    a board that cannot be rendered gives a reason, not an error."""

    RENDER = "pcbdata.kicad.previews:render_svg"

    def __init__(self, workers: int = 2, timeout: float = 120.0):
        self.timeout = timeout
        self._pool = KicadPool(workers=workers, task_timeout=timeout + 60)

    def __enter__(self) -> PreviewRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self._pool.close()

    def render(self, jobs: list[tuple[Path, Path]]) -> list[str | None]:
        """Renders each (board file, output SVG) pair; returns, per pair, None or the reason
        it could not. A board is rendered with the project of its own stem, if any."""
        args = []
        for board, _ in jobs:
            project = board.with_suffix(".kicad_pro")
            args.append((str(board), str(project) if project.is_file() else None, self.timeout))
        problems: list[str | None] = [None] * len(jobs)
        for outcome in self._pool.map(self.RENDER, args):
            board, out_path = jobs[outcome.index]
            value = outcome.value if outcome.ok else {"reason": outcome.error}
            if "svg" not in value:
                problems[outcome.index] = value["reason"]
                continue
            # KiCad stamps the export time into the title; drop it so re-publishing is stable.
            text = re.sub(r"<title>.*?</title>", f"<title>{escape(board.parent.name)}</title>",
                          value["svg"], count=1, flags=re.S)
            write_file(out_path, text)
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

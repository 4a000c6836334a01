"""Board pictures from plain records: an RGB uint8 array (numpy + Pillow, no KiCad).

A leaf module: it draws what it is given and knows nothing of KiCad, the environment or the
CLI. The records are integer nanometres (KiCad's units, as `pcbdata.kicad.board_records` and
the environment's KiCad session report them):

    {"layers": ["F.Cu", "B.Cu"],                     # copper stack, top first
     "outline": [[(x, y), ...], ...],                # Edge.Cuts rings
     "pads": [{"x", "y", "drill", "polygons": {layer: [[(x, y), ...], ...]}}],
     "zones": [{"layer", "polygon": [(x, y), ...]}],  # filled copper (also copper drawings)
     "tracks": [{"layer", "start", "end", "width", "mid" (arcs only)}],
     "vias": [{"x", "y", "diameter", "drill"}],
     "ratsnest": [(x1, y1, x2, y2), ...],            # open connections
     "head": (x, y, layer name) or None,             # the router's head
     "markers": [(x, y), ...]}                       # DRC violations

Missing keys mean "none". Drawing is deterministic (no anti-aliasing, fixed colours, fixed
order: same records and size give the same bytes). Colours: `LAYER_COLOURS` (and the legend
in docs/render.md).
"""
from __future__ import annotations

import io
import math

import numpy as np
from PIL import Image, ImageDraw

RGB = tuple[int, int, int]

#: Fixed colour per copper layer (KiCad's defaults, slightly toned): F.Cu red, B.Cu blue,
#: inner layers in a fixed cycle. Layers are drawn bottom first, so F.Cu is on top.
LAYER_COLOURS: dict[str, RGB] = {"F.Cu": (200, 52, 52), "B.Cu": (77, 127, 196)}
INNER_COLOURS: tuple[RGB, ...] = ((194, 194, 0), (194, 0, 194), (0, 170, 120),
                                  (230, 140, 40), (120, 90, 220), (0, 170, 200))
BACKGROUND: RGB = (24, 24, 28)
BOARD: RGB = (44, 48, 44)
OUTLINE: RGB = (208, 200, 120)
HOLE: RGB = (12, 12, 12)
VIA: RGB = (190, 190, 190)
RATSNEST: RGB = (240, 240, 240)
HEAD: RGB = (40, 230, 90)
MARKER: RGB = (255, 0, 255)
DEFAULT_SIZE = (640, 480)


def layer_colour(name: str) -> RGB:
    """The colour of a copper layer: F.Cu and B.Cu fixed, InN.Cu from `INNER_COLOURS`."""
    if name in LAYER_COLOURS:
        return LAYER_COLOURS[name]
    digits = "".join(ch for ch in name if ch.isdigit())
    return INNER_COLOURS[(int(digits) - 1) % len(INNER_COLOURS) if digits else 0]


class _Frame:
    """Board nanometres to pixels: the bounding box fitted into the image, aspect kept."""

    def __init__(self, points: list[tuple[int, int]], size: tuple[int, int], margin: int):
        width, height = size
        xs, ys = [p[0] for p in points] or [0], [p[1] for p in points] or [0]
        self.x0, self.y0 = min(xs), min(ys)
        span_x, span_y = max(max(xs) - self.x0, 1), max(max(ys) - self.y0, 1)
        self.scale = min((width - 2 * margin) / span_x, (height - 2 * margin) / span_y)
        self.ox = (width - span_x * self.scale) / 2
        self.oy = (height - span_y * self.scale) / 2

    def pt(self, x: float, y: float) -> tuple[int, int]:
        return (round(self.ox + (x - self.x0) * self.scale),
                round(self.oy + (y - self.y0) * self.scale))

    def length(self, nm: float, least: int = 1) -> int:
        return max(least, round(nm * self.scale))


def _extent(records: dict) -> list[tuple[int, int]]:
    """Points that must be in the picture: the outline, else every item."""
    points = [tuple(p) for ring in records.get("outline", []) for p in ring]
    if points:
        return points
    points = [(p["x"], p["y"]) for p in records.get("pads", [])]
    for track in records.get("tracks", []):
        points += [tuple(track["start"]), tuple(track["end"])]
    points += [(v["x"], v["y"]) for v in records.get("vias", [])]
    return points


def _arc_points(start, mid, end, steps: int = 16) -> list[tuple[float, float]]:
    """Points along the circle through start, mid, end (a straight chain if they are
    collinear)."""
    (ax, ay), (bx, by), (cx, cy) = start, mid, end
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if d == 0:
        return [start, mid, end]
    ux = ((ax * ax + ay * ay) * (by - cy) + (bx * bx + by * by) * (cy - ay)
          + (cx * cx + cy * cy) * (ay - by)) / d
    uy = ((ax * ax + ay * ay) * (cx - bx) + (bx * bx + by * by) * (ax - cx)
          + (cx * cx + cy * cy) * (bx - ax)) / d
    radius = math.hypot(ax - ux, ay - uy)
    a0, am, a1 = (math.atan2(p[1] - uy, p[0] - ux) for p in (start, mid, end))
    sweep = (a1 - a0) % (2 * math.pi)
    if (am - a0) % (2 * math.pi) > sweep:  # the mid point lies on the other way round
        sweep -= 2 * math.pi
    return [(ux + radius * math.cos(a0 + sweep * k / steps),
             uy + radius * math.sin(a0 + sweep * k / steps)) for k in range(steps + 1)]


def _capsule(draw: ImageDraw.ImageDraw, frame: _Frame, points, width: int, colour: RGB) -> None:
    pixels = [frame.pt(*p) for p in points]
    w = frame.length(width)
    draw.line(pixels, fill=colour, width=w)
    r = w / 2
    for x, y in (pixels[0], pixels[-1]):
        draw.ellipse((x - r, y - r, x + r, y + r), fill=colour)


def _disc(draw: ImageDraw.ImageDraw, frame: _Frame, x: int, y: int, diameter: int,
          colour: RGB) -> None:
    cx, cy = frame.pt(x, y)
    r = frame.length(diameter) / 2
    draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=colour)


def _polygon(draw: ImageDraw.ImageDraw, frame: _Frame, ring, colour: RGB) -> None:
    pixels = [frame.pt(*p) for p in ring]
    if len(pixels) >= 3:
        draw.polygon(pixels, fill=colour, outline=colour)
    elif pixels:
        draw.point(pixels, fill=colour)


def _layer(draw: ImageDraw.ImageDraw, frame: _Frame, records: dict, name: str) -> None:
    colour = layer_colour(name)
    for zone in records.get("zones", []):
        if zone["layer"] == name:
            _polygon(draw, frame, zone["polygon"], colour)
    for track in records.get("tracks", []):
        if track["layer"] != name:
            continue
        points = _arc_points(track["start"], track["mid"], track["end"]) \
            if track.get("mid") else [track["start"], track["end"]]
        _capsule(draw, frame, points, track["width"], colour)
    for pad in records.get("pads", []):
        for ring in pad.get("polygons", {}).get(name, []):
            _polygon(draw, frame, ring, colour)


def _outline(draw: ImageDraw.ImageDraw, frame: _Frame, rings) -> None:
    for k, ring in enumerate(rings):
        pixels = [frame.pt(*p) for p in ring]
        if len(pixels) < 3:
            continue
        if k == 0:
            draw.polygon(pixels, fill=BOARD)
        draw.line(pixels + [pixels[0]], fill=OUTLINE, width=1)


def _holes(draw: ImageDraw.ImageDraw, frame: _Frame, records: dict) -> None:
    for via in records.get("vias", []):
        _disc(draw, frame, via["x"], via["y"], via["diameter"], VIA)
        _disc(draw, frame, via["x"], via["y"], via["drill"], HOLE)
    for pad in records.get("pads", []):
        if pad.get("drill"):
            _disc(draw, frame, pad["x"], pad["y"], pad["drill"], HOLE)


def _overlays(draw: ImageDraw.ImageDraw, frame: _Frame, records: dict) -> None:
    for x1, y1, x2, y2 in records.get("ratsnest", []):
        draw.line([frame.pt(x1, y1), frame.pt(x2, y2)], fill=RATSNEST, width=1)
    for x, y in records.get("markers", []):
        cx, cy = frame.pt(x, y)
        draw.line([(cx - 6, cy - 6), (cx + 6, cy + 6)], fill=MARKER, width=2)
        draw.line([(cx - 6, cy + 6), (cx + 6, cy - 6)], fill=MARKER, width=2)
        draw.ellipse((cx - 8, cy - 8, cx + 8, cy + 8), outline=MARKER, width=1)
    head = records.get("head")
    if head:
        cx, cy = frame.pt(head[0], head[1])
        colour = layer_colour(head[2])
        draw.ellipse((cx - 7, cy - 7, cx + 7, cy + 7), outline=HEAD, width=2)
        draw.ellipse((cx - 3, cy - 3, cx + 3, cy + 3), fill=colour, outline=HEAD)


def draw_board(records: dict, size: tuple[int, int] = DEFAULT_SIZE, margin: int = 8) -> np.ndarray:
    """The board as an RGB uint8 array of shape (height, width, 3): background, board area and
    outline, copper per layer (bottom layer first), via and drill holes, ratsnest lines, DRC
    markers, the head."""
    width, height = size
    image = Image.new("RGB", (width, height), BACKGROUND)
    draw = ImageDraw.Draw(image)
    frame = _Frame(_extent(records), size, margin)
    _outline(draw, frame, records.get("outline", []))
    for name in reversed(list(records.get("layers", []))):
        _layer(draw, frame, records, name)
    _holes(draw, frame, records)
    _overlays(draw, frame, records)
    return np.asarray(image, dtype=np.uint8)


def side_by_side(images: list[np.ndarray], titles: list[str] | None = None,
                 gap: int = 6) -> np.ndarray:
    """Pictures in one row (same height), each with an optional title line above."""
    bar = 14 if titles else 0
    height = max(im.shape[0] for im in images) + bar
    width = sum(im.shape[1] for im in images) + gap * (len(images) - 1)
    canvas = Image.new("RGB", (width, height), BACKGROUND)
    draw = ImageDraw.Draw(canvas)
    x = 0
    for k, im in enumerate(images):
        canvas.paste(Image.fromarray(im), (x, bar))
        if titles:
            draw.text((x + 4, 1), titles[k], fill=RATSNEST)
        x += im.shape[1] + gap
    return np.asarray(canvas, dtype=np.uint8)


def png_bytes(image: np.ndarray) -> bytes:
    """PNG bytes of an RGB array; fixed settings and no metadata, so the bytes depend only on
    the pixels."""
    out = io.BytesIO()
    Image.fromarray(image).save(out, format="PNG", optimize=False, compress_level=9)
    return out.getvalue()


def png_image(data: bytes) -> np.ndarray:
    """The RGB array of PNG bytes (`png_bytes`' inverse)."""
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"), dtype=np.uint8)


CHART_W, CHART_H, CHART_PAD = 360, 200, 30


def _chart_panel(draw: ImageDraw.ImageDraw, ox: int, oy: int, title: str, points) -> None:
    draw.rectangle((ox, oy, ox + CHART_W - 1, oy + CHART_H - 1), outline=(0, 0, 0))
    draw.text((ox + 6, oy + 4), title, fill=(0, 0, 0))
    if not points:
        return
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    lo, hi = min(ys), max(ys)
    span_x, span_y = (max(xs) - min(xs)) or 1, (hi - lo) or 1
    draw.text((ox + 6, oy + CHART_H - 14), f"min {lo:.3g}  max {hi:.3g}  last {ys[-1]:.3g}",
              fill=(80, 80, 80))

    def at(x, y):
        return (ox + CHART_PAD + (x - min(xs)) / span_x * (CHART_W - 2 * CHART_PAD),
                oy + CHART_H - CHART_PAD - (y - lo) / span_y * (CHART_H - 2 * CHART_PAD))

    pts = [at(x, y) for x, y in points]
    if len(pts) > 1:
        draw.line(pts, fill=(30, 90, 200), width=2)
    for x, y in pts:
        draw.rectangle((x - 2, y - 2, x + 2, y + 2), fill=(200, 60, 30))


Points = list[tuple[float, float]]


def line_charts(panels: list[tuple[str, Points]], columns: int = 2) -> np.ndarray:
    """Line charts of (title, points) panels on a grid, as an RGB array: deterministic (no
    anti-aliasing, fixed colours), e.g. a learning curve."""
    rows = max(1, -(-len(panels) // columns))
    image = Image.new("RGB", (columns * CHART_W, rows * CHART_H), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    draw.fontmode = "1"
    for n, (title, points) in enumerate(panels):
        _chart_panel(draw, (n % columns) * CHART_W, (n // columns) * CHART_H, title, points)
    return np.asarray(image, dtype=np.uint8)

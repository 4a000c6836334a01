"""The learning curve of a run as a PNG (Pillow): return per update, validation CP and return,
steps per second. Deterministic drawing (no anti-aliasing, fixed colours)."""
from __future__ import annotations

import os
from pathlib import Path

from PIL import Image, ImageDraw

PANELS = (("return", "episode return (train)"), ("val_cp", "CP on validation"),
          ("val_return", "return on validation"), ("steps_per_s", "env steps/s incl. learning"))
W, H, PAD = 360, 200, 30


def _panel(draw: ImageDraw.ImageDraw, ox: int, oy: int, title: str, points) -> None:
    draw.rectangle((ox, oy, ox + W - 1, oy + H - 1), outline=(0, 0, 0))
    draw.text((ox + 6, oy + 4), title, fill=(0, 0, 0))
    if not points:
        return
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    lo, hi = min(ys), max(ys)
    span_x, span_y = (max(xs) - min(xs)) or 1, (hi - lo) or 1
    draw.text((ox + 6, oy + H - 14), f"min {lo:.3g}  max {hi:.3g}  last {ys[-1]:.3g}",
              fill=(80, 80, 80))

    def at(x, y):
        return (ox + PAD + (x - min(xs)) / span_x * (W - 2 * PAD),
                oy + H - PAD - (y - lo) / span_y * (H - 2 * PAD))

    pts = [at(x, y) for x, y in points]
    if len(pts) > 1:
        draw.line(pts, fill=(30, 90, 200), width=2)
    for x, y in pts:
        draw.rectangle((x - 2, y - 2, x + 2, y + 2), fill=(200, 60, 30))


def draw_curve(log: list[dict], path: Path) -> None:
    image = Image.new("RGB", (2 * W, 2 * H), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    draw.fontmode = "1"
    for n, (key, title) in enumerate(PANELS):
        points = [(r["update"], r[key]) for r in log if r.get(key) is not None]
        _panel(draw, (n % 2) * W, (n // 2) * H, title, points)
    tmp = path.with_name(f".{path.name}.tmp")
    image.save(tmp, format="PNG")
    os.replace(tmp, path)

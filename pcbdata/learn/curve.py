"""The learning curve of a run as a PNG: return per update, validation CP and return, steps
per second (`pcbdata.core.drawing.line_charts`)."""
from __future__ import annotations

from pathlib import Path

from pcbdata.core.drawing import line_charts, png_bytes
from pcbdata.core.fsutil import write_atomic

PANELS = (("return", "episode return (train)"), ("val_cp", "CP on validation"),
          ("val_return", "return on validation"), ("steps_per_s", "env steps/s incl. learning"))


def draw_curve(log: list[dict], path: Path) -> None:
    panels = [(title, [(r["update"], r[key]) for r in log if r.get(key) is not None])
              for key, title in PANELS]
    write_atomic(path, png_bytes(line_charts(panels)))

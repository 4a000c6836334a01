"""The learning curve of a run as a PNG: return per update, validation CP, return, WL and
vias, steps per second (`pcbdata.core.drawing.line_charts`); the first panel's title names the
run's variant (algorithm, reward, finish, weights)."""
from __future__ import annotations

from pathlib import Path

from pcbdata.core.drawing import line_charts, png_bytes
from pcbdata.core.fsutil import write_atomic

PANELS = (("return", "train return"), ("val_cp", "CP on validation"),
          ("val_return", "return on validation"), ("steps_per_s", "env steps/s incl. learning"),
          ("val_wl", "WL on validation (mm)"), ("val_vias", "vias on validation"))


def draw_curve(log: list[dict], path: Path, label: str = "") -> None:
    panels = [(title + (f": {label}" if label and n == 0 else ""),
               [(r["update"], r[key]) for r in log if r.get(key) is not None])
              for n, (key, title) in enumerate(PANELS)]
    write_atomic(path, png_bytes(line_charts(panels)))

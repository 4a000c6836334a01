"""The reward-weight sweep's two marginal lines on D2 (SPEC 7.3): lambda_w in 0 / 0.001 / 0.002
at the default lambda_v, and lambda_v in 0 / 0.05 / 0.1 at the default lambda_w (5 cells: the
default cell is on both lines). Each cell and seed is a PPO fine-tune (`pcbdata train --init`)
of at most `--minutes` of wall time from one cloned starting point, then greedy episodes of its
last weights on `--eval-boards` D2-validation boards: CP, WL (mm), vias, return under the
cell's own weights. The starting point is evaluated the same way (the baseline: the default
cell's validation before its first update). The report
says whether WL falls as lambda_w rises and vias fall as lambda_v rises (cell means over seeds).

The published budget is 2 seeds and up to 10 minutes per cell on 2 cores (about 2 hours):

    .venv/bin/python bench/bench_reward_sweep.py --out RUNS [--seeds 2] [--minutes 10]
        [--start CHECKPOINT | --bc-boards 512 --bc-epochs 20] [--eval-boards 64]
        [--record bench/runs/NAME.json]

Without `--start`, the starting point is cloned once into RUNS/clone (`pcbdata train
--updates 0`). Cells already finished in RUNS are not run again (their run folders resume).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench._measure import machine  # noqa: E402

DEFAULT_LW, DEFAULT_LV = 0.002, 0.1
LW_LINE = (0.0, 0.001, 0.002)
LV_LINE = (0.0, 0.05, 0.1)
#: The five cells: the lambda_w line at the default lambda_v, then the rest of the lambda_v line.
CELLS = [(lw, DEFAULT_LV) for lw in LW_LINE] + [(DEFAULT_LW, lv) for lv in LV_LINE[:-1]]
#: Published marginal means along each line (SPEC 7.5 / 7.3).
PUBLISHED = {"wl_along_lw": [484.8, 468.4, 462.4], "vias_along_lv": [4.06, 2.82, 2.27]}


def _log(line: str) -> None:
    print(line, flush=True)


def starting_point(args, out: Path) -> Path:
    if args.start:
        return Path(args.start)
    from pcbdata.learn.train import Settings, train

    clone = out / "clone"
    train(clone, Settings(bc_boards=args.bc_boards, bc_epochs=args.bc_epochs, updates=0,
                          val_boards=args.eval_boards), log=_log)
    return clone / "best.pt"


def validation_figures(row: dict) -> dict:
    """CP, WL, vias and return of a validation row of a run's log."""
    return {"cp": row["val_cp"], "wl_mm": row["val_wl"], "vias": row["val_vias"],
            "return": row["val_return"]}


def run_cell(args, out: Path, start: Path, lw: float, lv: float, seed: int) -> dict:
    from pcbdata.learn.train import Settings, train

    folder = out / f"lw{lw:g}-lv{lv:g}-seed{seed}"
    s = Settings(seed=seed, lw=lw, lv=lv, init=str(start), updates=100_000,
                 minutes=args.minutes, val_boards=args.eval_boards, val_every=100_000,
                 checkpoint_every=100_000)
    result_path = folder / "sweep.json"
    if result_path.is_file():
        return json.loads(result_path.read_text())
    began = time.perf_counter()
    progress = train(folder, s, log=_log)
    seconds = time.perf_counter() - began
    rows = [r for r in progress["log"] if r["phase"] == "ppo"]
    # the start's validation, then the last update's (both on the eval boards)
    result = {"lw": lw, "lv": lv, "seed": seed, "updates": progress["update"],
              "env_steps": int(sum(r["env_steps"] for r in rows)), "train_seconds": seconds,
              **validation_figures(rows[-1]), "start": validation_figures(progress["log"][0])}
    result_path.write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    return result


def _mean(results: list[dict], lw: float, lv: float, key: str) -> float:
    return float(np.mean([r[key] for r in results if (r["lw"], r["lv"]) == (lw, lv)]))


def _spread(values: list[float], digits: int) -> str:
    """mean, or mean +- sample std over seeds."""
    if len(values) < 2:
        return f"{np.mean(values):.{digits}f}"
    return f"{np.mean(values):.{digits}f} +- {np.std(values, ddof=1):.{digits}f}"


def figures(results: list[dict], start: dict) -> dict:
    """The docs' tables (bench/doc_tables.py): one row per cell, one per line."""
    cells = [{"lambda_w": "start", "lambda_v": "", "seeds": "", "updates": "",
              "CP": f"{start['cp']:.3f}", "WL (mm)": f"{start['wl_mm']:.1f}",
              "vias": f"{start['vias']:.3f}"}]
    for lw, lv in CELLS:
        mine = [r for r in results if (r["lw"], r["lv"]) == (lw, lv)]
        cells.append({"lambda_w": lw, "lambda_v": lv, "seeds": len(mine),
                      "updates": _spread([r["updates"] for r in mine], 0),
                      "CP": _spread([r["cp"] for r in mine], 3),
                      "WL (mm)": _spread([r["wl_mm"] for r in mine], 1),
                      "vias": _spread([r["vias"] for r in mine], 3)})
    d = directions(results)
    lines = [{"line": "WL (mm) as lambda_w goes 0 / 0.001 / 0.002",
              "measured": " / ".join(f"{v:.1f}" for v in d["wl_along_lw"]),
              "published": " / ".join(map(str, PUBLISHED["wl_along_lw"])),
              "falls": "yes" if d["wl_falls_as_lw_rises"] else "no"},
             {"line": "vias as lambda_v goes 0 / 0.05 / 0.1",
              "measured": " / ".join(f"{v:.3f}" for v in d["vias_along_lv"]),
              "published": " / ".join(map(str, PUBLISHED["vias_along_lv"])),
              "falls": "yes" if d["vias_fall_as_lv_rise"] else "no"}]
    return {"cells": cells, "lines": lines}


def directions(results: list[dict]) -> dict:
    """Cell means along each line, and whether they fall as the weight rises."""
    wl = [_mean(results, lw, DEFAULT_LV, "wl_mm") for lw in LW_LINE]
    vias = [_mean(results, DEFAULT_LW, lv, "vias") for lv in LV_LINE]
    return {"wl_along_lw": wl, "vias_along_lv": vias,
            "wl_falls_as_lw_rises": bool(wl[0] > wl[1] > wl[2]),
            "wl_lower_at_0.002_than_at_0": bool(wl[2] < wl[0]),
            "vias_fall_as_lv_rise": bool(vias[0] > vias[1] > vias[2]),
            "vias_lower_at_0.1_than_at_0": bool(vias[2] < vias[0])}


def record(result: dict, path: str | None) -> None:
    """Prints the run as JSON and writes it to `path`; keys keep their order (the tables'
    columns are in the rows' order)."""
    text = json.dumps(result, indent=1)
    print(text)
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(text + "\n", encoding="utf-8")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="folder of the runs (resumable)")
    ap.add_argument("--seeds", type=int, default=2, help="seeds per cell (0, 1, ...)")
    ap.add_argument("--minutes", type=float, default=10.0, help="fine-tune wall time per cell")
    ap.add_argument("--start", help="the cloned starting point (default: clone one)")
    ap.add_argument("--bc-boards", type=int, default=512, help="cloning boards (no --start)")
    ap.add_argument("--bc-epochs", type=int, default=20, help="cloning epochs (no --start)")
    ap.add_argument("--eval-boards", type=int, default=64, help="D2-validation boards, greedy")
    ap.add_argument("--record", help="JSON file for the run's data (bench/runs/...)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    began = datetime.now(UTC)
    load = os.getloadavg()[0]
    start = starting_point(args, out)
    results = [run_cell(args, out, start, lw, lv, seed)
               for seed in range(args.seeds) for lw, lv in CELLS]
    baseline = next(r["start"] for r in results if (r["lw"], r["lv"]) == (DEFAULT_LW, DEFAULT_LV))
    record({"command": "python bench/bench_reward_sweep.py " + " ".join(argv or sys.argv[1:]),
            "machine": machine(), "date": began.strftime("%Y-%m-%d %H:%M UTC"),
            "budget": {"seeds": args.seeds, "minutes_per_cell": args.minutes,
                       "eval_boards": args.eval_boards, "start": str(start),
                       **({} if args.start else {"bc_boards": args.bc_boards,
                                                 "bc_epochs": args.bc_epochs})},
            "load": f"load average {load:.1f} before, {os.getloadavg()[0]:.1f} after (2 cores "
                    "shared with other jobs)",
            "figures": figures(results, baseline),
            "notes": "CP, WL and vias: greedy episodes of each cell's last weights on the first "
                     f"{args.eval_boards} D2-validation boards; cell means over seeds (+- the "
                     "sample std with 2 or more seeds).",
            "starting_point": baseline, "runs": results, "published": PUBLISHED,
            **directions(results)}, args.record)


if __name__ == "__main__":
    main()

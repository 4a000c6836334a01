"""How much synthetic boards look like the real D3 tiers (SPEC section 2b, docs/realism.md).

    python bench/bench_realism.py --d3 D3_DIR --synthetic SET_DIR --config d2r-b --tier B
        [--split train] [--limit N] [--md PATH] [--json PATH] [--classifier --samples 20]
        [--difficulty --agent scripted-shove --boards 64 --workers 2]
    python bench/bench_realism.py --d3 D3_DIR --write-targets PATH
    python bench/bench_realism.py --d3 D3_DIR --noise [--draws 1000] [--tier A]
    python bench/bench_realism.py --d3 D3_DIR --noise --classifier [--draws 10 --samples 20]
    python bench/bench_realism.py --d3 D3_DIR --synthetic SET_DIR --config d2r-a --tier A
        --half extended --pcbench PCBENCH_DIR [--external-work DIR]

Both sides are measured from the board files (`pcbdata.realism.statistics`). A tier's
rows are its boards in `characteristics.csv` order (the table order: pads, nets, components,
name); row number = the 1-based position among that tier's rows. Odd row numbers are the
calibration half (what a generator may be tuned on, `--write-targets`), even ones the
held-out half the Kolmogorov-Smirnov distances are measured against; the halves are shipped by
name (`pcbdata/resources/realism/calibration.json`: the D3 1.0.0 table's), so later D3 rows do
not move boards between them. Each distance is shown against SPEC 2b's bound, max(0.15, the 1 %
critical value of the two sample sizes); `--classifier` adds the joint test (ROC AUC of a
gradient-boosted classifier, target 0.65); `--noise --classifier` gives that test's floor.
With `--pcbench`, the calibration side may add the PCBench boards of the tier's size that D3's
revalidation dropped (`--half extended`, `pcbdata.realism.external`): more real
boards to fit on, none of the held-out half.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import machine  # noqa: E402

from pcbdata.core import tree  # noqa: E402
from pcbdata.realism.classifier import AUC_TARGET, classifier_auc  # noqa: E402
from pcbdata.realism.external import external_samples  # noqa: E402
from pcbdata.realism.noise import (  # noqa: E402
    ClassifierFloor,
    NoiseFloor,
    calibration_copy_aucs,
    calibration_copy_distances,
    perfect_generator_distances,
    real_split_aucs,
)
from pcbdata.realism.statistics import (  # noqa: E402
    NET_SHAPES,
    PER_NET,
    STATISTICS,
    BoardStatistics,
    board_statistics,
    ks_distance,
    pooled_samples,
    summary,
    weighted_samples,
)

TIERS = ("A", "B", "C")
#: SPEC 2b: every distance at most this.
KS_TARGET = 0.15
D3_SPLIT = "full"
#: Statistics with few integer values: the targets add their full frequency table.
DISCRETE = ("layers", PER_NET)


@dataclass(frozen=True)
class Board:
    board_id: str
    path: Path


def tier_config(tier: str) -> str:
    return f"d3-{tier.lower()}"


def d3_tier_boards(d3_root: Path, tier: str) -> list[Board]:
    """The tier's boards in `characteristics.csv` order (its `full` split: the whole tier)."""
    with open(d3_root / tree.CHARACTERISTICS_CSV, newline="", encoding="utf-8") as handle:
        rows = [r for r in csv.DictReader(handle) if r["tier"] == tier]
    config = tier_config(tier)
    return [Board(r["board_id"], tree.board_dir(d3_root, config, D3_SPLIT, r["board_id"])
                  / tree.BOARD_FILE) for r in rows]


def calibration_names(tier: str) -> frozenset[str]:
    """The tier's calibration half by board name, as shipped
    (`pcbdata/resources/realism/calibration.json`: the odd positions of the tier in the D3
    1.0.0 table, which the levels were calibrated on)."""
    import json

    from pcbdata.resources import resource_path

    data = json.loads(resource_path("realism", "calibration.json").read_text(encoding="utf-8"))
    return frozenset(data["tiers"][tier])


def halves(boards: list[Board], tier: str) -> tuple[list[Board], list[Board]]:
    """(calibration, held out): the shipped calibration half by name, the rest of the tier
    held out (boards D3 gained since join it), both in table order."""
    names = calibration_names(tier)
    calibration = [b for b in boards if b.board_id[5:] in names]
    return calibration, [b for b in boards if b.board_id[5:] not in names]


def synthetic_boards(root: Path, config: str, split: str, limit: int | None) -> list[Board]:
    found = [Board(board_id, folder / tree.BOARD_FILE)
             for board_id, folder in tree.list_instances(root, config, split)]
    return found[:limit] if limit else found


def measure(boards: list[Board]) -> list[BoardStatistics]:
    return [board_statistics(b.path) for b in boards]


def targets(d3_root: Path, external: dict | None = None) -> dict:
    """Per tier, the calibration half's summary of every statistic (and, given the dropped
    PCBench boards of each tier's size, that of the extended sample)."""
    out: dict = {"definitions": _definitions(), "source": str(d3_root), "tiers": {}}
    for tier in TIERS:
        calibration, _ = halves(d3_tier_boards(d3_root, tier), tier)
        stats = measure(calibration)
        out["tiers"][tier] = {"boards": len(calibration),
                              "board_ids": [b.board_id for b in calibration],
                              **_summaries(stats)}
        if external is not None:
            sample = external[tier]
            out["tiers"][tier]["extended"] = {
                "pad_range": list(sample.pad_range),
                "external_boards": dict(zip([b.name for b in sample.boards],
                                            sample.weights(stats), strict=True))}
    return out


def _summaries(stats: list[BoardStatistics]) -> dict:
    samples = pooled_samples(stats)
    return {"statistics": {name: summary(samples[name]) for name in STATISTICS},
            "frequencies": {name: _frequencies(samples[name]) for name in DISCRETE}}


def _frequencies(values: list[float]) -> dict[str, int]:
    counts: dict[int, int] = {}
    for value in values:
        counts[int(value)] = counts.get(int(value), 0) + 1
    return {str(k): counts[k] for k in sorted(counts)}


def _definitions() -> dict:
    return {
        "row_number": "1-based position of a board among its tier's rows of D3's "
                      "characteristics.csv, in that file's order (pads, nets, components, "
                      "name); calibration half = odd row numbers (1, 3, 5, ...), held-out "
                      "half = even",
        "nets": "nets with >= 2 copper pads on the board (= characteristics.csv nets)",
        "pads": "terminal pads: copper pads on those nets (= characteristics.csv pads, "
                "but one board: 0388_kitspace_bomanz, see docs/realism.md)",
        "components": "footprints on the board (= characteristics.csv components)",
        "pads_per_net": "pad count of each net with >= 2 pads; the sample pools every net of "
                        "every board (count = nets, not boards)",
        "layers": "copper layers of the board's layer table (= characteristics.csv layers)",
        "pad_density": "terminal pads per cm2 of the Edge.Cuts outline's area (holes cut "
                       "out); boards whose outline closes nothing are left out",
        "pad_pitch": "per footprint with >= 2 distinct copper pad centres the smallest "
                     "centre distance (mm); per board the median; boards without such a "
                     "footprint are left out",
        "quantiles": "numpy.percentile, linear interpolation; frequencies: value -> count "
                     "for the discrete layers and pads_per_net",
        "ks": "two-sample Kolmogorov-Smirnov distance (sup of the gap between the empirical "
              "CDFs) of the synthetic sample vs the held-out half; target <= 0.15 each",
        "extended": "calibration half + the PCBench boards D3's revalidation dropped "
                    "(DRC errors or unconnected items) whose terminal pads lie in the tier's "
                    "range, measured on KiCad 9's save of them, each with the weight that "
                    "gives them the calibration half's pads distribution (name -> weight; "
                    "pcbdata.realism.external)",
        "measure": "python bench/bench_realism.py --d3 D3_DIR --synthetic SET_DIR "
                   "--config d2r-b --tier B --split train [--limit 512] [--md T.md]: the KS "
                   "table vs the held-out half (the library side is "
                   "pcbdata.realism.statistics: board_statistics(path) -> the seven "
                   "statistics of one board file, pooled_samples, ks_distance)",
    }


def ks_table(d3_root: Path, tiers: list[str], synthetic: list[BoardStatistics] | None,
             half: str = "held-out", external: dict | None = None) -> dict:
    """Per tier and statistic: KS distance between the tier's `half` and the synthetic set
    (None: the tier's calibration half against its held-out half, the distance that sampling
    alone gives), with the 95 % critical value of the two sample sizes. `half` "extended" is
    the calibration half with `external[tier]`'s boards weighted to its pads
    (`pads_matched_weights`); without a synthetic set, that sample against the held-out half."""
    table: dict = {}
    for tier in tiers:
        calibration, held_out = halves(d3_tier_boards(d3_root, tier), tier)
        cal_stats, held_stats = measure(calibration), measure(held_out)
        tier_side = (cal_stats, [1.0] * len(cal_stats))
        if half == "extended":
            sample = external[tier]
            tier_side = (cal_stats + sample.statistics,
                         tier_side[1] + sample.weights(cal_stats))
        held_side = (held_stats, [1.0] * len(held_stats))
        if synthetic is None:
            real, ours = held_side, tier_side
        else:
            real = held_side if half == "held-out" else tier_side
            ours = (synthetic, [1.0] * len(synthetic))
        table[tier] = _distances(real, ours)
    return table


def _distances(real: tuple[list, list[float]], ours: tuple[list, list[float]]) -> dict:
    """KS distances and critical values of two weighted board samples (stats, weights); a
    weighted sample's size is its effective one, (sum w)^2 / sum w^2."""
    real_samples, our_samples = weighted_samples(*real), weighted_samples(*ours)
    names = STATISTICS + NET_SHAPES
    out: dict = {"boards": len(real[0]), "counts": {}, "distances": {}, "critical_95": {}}
    for name in names:
        (a, wa), (b, wb) = real_samples[name], our_samples[name]
        counts = [_effective_size(wa), _effective_size(wb)]
        out["counts"][name] = counts
        out["distances"][name] = ks_distance(a, b, wa, wb)
        out["critical_95"][name] = _critical(*counts)
        out.setdefault("bound", {})[name] = spec_bound(*counts)
    return out


def spec_bound(n: int, m: int) -> float | None:
    """SPEC 2b's bound on a statistic's KS distance for samples of n and m boards:
    max(0.15, c), c = 1.63 sqrt((n + m) / (n m)) the 1 % two-sample critical value."""
    if not n or not m:
        return None
    return round(max(KS_TARGET, 1.63 * math.sqrt((n + m) / (n * m))), 3)


# --- the joint test: a classifier that tells real boards from level boards ----------------
# (pcbdata.realism.classifier; its floor: classifier_noise_table below)

def classifier_table(d3_root: Path, tier: str, synthetic: list[BoardStatistics],
                     samples: int, half: str = "held-out") -> dict:
    """The classifier test of a tier: the real boards of `half` (SPEC 2b: held-out; or
    calibration) against `samples` disjoint level samples of the same size (mean and spread of
    the AUC, mean importances), and the same test other half against that half (below 0.5:
    the halves interleave in pads; the floor is `classifier_noise_table`)."""
    import statistics as stats_

    if half not in ("held-out", "calibration"):
        raise SystemExit(f"bench_realism: the classifier test is against the held-out or the "
                         f"calibration half, not {half}")
    calibration, held_out = halves(d3_tier_boards(d3_root, tier), tier)
    if half == "calibration":
        calibration, held_out = held_out, calibration
    real, cal = measure(held_out), measure(calibration)
    m = len(real)
    if len(synthetic) < samples * m:
        raise SystemExit(f"the classifier test of D3-{tier} needs {samples} x {m} level "
                         f"boards, the set has {len(synthetic)}")
    runs = [classifier_auc(real, synthetic[k * m:(k + 1) * m], seed=k) for k in range(samples)]
    aucs = [auc for auc, _ in runs]
    importance = {n: stats_.fmean(r[1][n] for r in runs) for n in STATISTICS}
    floor = classifier_auc(real, cal[:m] if len(cal) >= m else cal, seed=0)[0]
    return {"boards": m, "samples": samples, "auc_mean": stats_.fmean(aucs),
            "auc_std": stats_.stdev(aucs) if len(aucs) > 1 else 0.0,
            "auc_max": max(aucs), "importance": importance, "real_vs_real_auc": floor,
            "target": AUC_TARGET, "half": half}


def _effective_size(weights: list[float]) -> int:
    total = sum(weights)
    return round(total * total / sum(w * w for w in weights)) if total else 0


def _critical(n: int, m: int) -> float | None:
    """The asymptotic 95 % critical value of the two-sample KS distance (independent draws;
    the pooled nets of a board are not, so for pads per net it is only a guide)."""
    return round(1.358 * math.sqrt((n + m) / (n * m)), 3) if n and m else None


# --- noise: the distances sampling alone gives (pcbdata.realism.noise) ---------

def noise_table(d3_root: Path, tiers: list[str], draws: int) -> dict:
    """Per tier: a copy of the calibration half over random pads-interleaved splits and over
    the SPEC's split, and a generator drawing from the whole tier, against a held-out half."""
    table: dict = {}
    for tier in tiers:
        boards = measure(d3_tier_boards(d3_root, tier))
        held_out_size = len(boards) // 2
        floors = {
            "copy_random_split": calibration_copy_distances(boards, draws=draws),
            "copy_spec_split": calibration_copy_distances(boards, draws=draws, split="spec"),
            "perfect_generator": perfect_generator_distances(
                boards, held_out_size=held_out_size, draws=draws),
        }
        table[tier] = {"boards": len(boards), "held_out": held_out_size, "draws": draws,
                       **{key: _noise_summary(floor) for key, floor in floors.items()}}
    return table


#: The classifier floors of `--noise --classifier`, in table order: key, label.
CLASSIFIER_FLOORS = (
    ("copy_spec", "copy of the calibration half (bootstrap), SPEC halves"),
    ("smoothed_copy_spec", "smoothed copy, SPEC halves"),
    ("smoothed_copy_interleaved", "smoothed copy, random pads-interleaved halves"),
    ("smoothed_copy_random", "smoothed copy, random halves"),
    ("real_halves_spec", "calibration half itself, SPEC halves (fold seeds vary)"),
    ("real_halves_interleaved", "real half vs real half, random pads-interleaved halves"),
    ("permutation_null", "real half vs real half, random halves (labels shuffled)"),
)


def classifier_noise_table(d3_root: Path, tiers: list[str], draws: int, samples: int) -> dict:
    """Per tier, the classifier test's AUC for generators whose only error is sampling
    (`pcbdata.realism.noise`): copies of the calibration half (each draw `samples` level
    samples of the held-out half's size), plain and smoothed, and the two real halves against
    each other; `draws` splits (the SPEC's halves: `draws` x `samples` level samples; the real
    halves: `draws` x `samples` splits, the SPEC's own halves `samples` fold seeds)."""
    from pcbdata.realism.classifier import features
    from pcbdata.realism.noise import Smoother

    table: dict = {}
    for tier in tiers:
        start = time.perf_counter()
        boards = d3_tier_boards(d3_root, tier)
        names = calibration_names(tier)
        mask = [b.board_id[5:] in names for b in boards]
        stats = measure(boards)
        copies = {"copy_spec": {}, "smoothed_copy_spec": {"smoothing": 1.0},
                  "smoothed_copy_interleaved": {"smoothing": 1.0, "split": "interleaved"},
                  "smoothed_copy_random": {"smoothing": 1.0, "split": "random"}}
        floors = {key: calibration_copy_aucs(stats, mask, draws=draws, samples=samples, **kw)
                  for key, kw in copies.items()}
        floors["real_halves_spec"] = real_split_aucs(stats, mask, split="spec", draws=samples)
        floors["real_halves_interleaved"] = real_split_aucs(stats, mask, split="interleaved",
                                                            draws=draws * samples)
        floors["permutation_null"] = real_split_aucs(stats, mask, split="random",
                                                     draws=draws * samples)
        smoother = Smoother(features([s for s, m in zip(stats, mask, strict=True) if m]))
        table[tier] = {"boards": len(stats), "calibration": sum(mask),
                       "held_out": len(mask) - sum(mask), "target": AUC_TARGET,
                       "smoothing_bandwidths_log": {k: round(v, 4) for k, v in
                                                    smoother.bandwidths.items()},
                       "shared_pitches": len(smoother.shared_pitches),
                       **{key: _classifier_floor_summary(floors[key])
                          for key, _ in CLASSIFIER_FLOORS},
                       "seconds": round(time.perf_counter() - start, 1)}
        _say(f"D3-{tier}: classifier floors in {table[tier]['seconds']} s")
    return table


def _classifier_floor_summary(floor: ClassifierFloor) -> dict:
    return {"draws": floor.draws, "samples": floor.samples, "mean": round(floor.mean, 4),
            "std_one_sample": round(floor.std, 4),
            "std_of_draw_means": round(float(floor.draw_means.std(ddof=1)), 4)
            if floor.draws > 1 else 0.0,
            "draw_mean_p5_p50_p95": [round(floor.quantile(q), 4) for q in (5, 50, 95)],
            "share_of_draws_above_target": round(floor.share_above(AUC_TARGET), 4),
            "share_of_samples_above_target": round(floor.sample_share_above(AUC_TARGET), 4),
            "draw_means": [round(float(v), 4) for v in floor.draw_means]}


def classifier_noise_markdown(report: dict) -> str:
    lines = []
    for tier, row in report["classifier_noise"].items():
        lines += [f"D3-{tier} classifier floors ({row['calibration']} calibration, "
                  f"{row['held_out']} held-out boards; level samples of {row['held_out']}): "
                  f"ROC AUC mean, spread of one sample, 5 / 50 / 95 % of the draws' means, "
                  f"share of draws (their mean) and of single samples above "
                  f"{row['target']}", "",
                  "| floor | draws x samples | mean | spread | 5 / 50 / 95 % | draws above "
                  "| samples above |", "|---|---:|---:|---:|---:|---:|---:|"]
        for key, label in CLASSIFIER_FLOORS:
            f = row[key]
            p5, p50, p95 = f["draw_mean_p5_p50_p95"]
            lines.append(f"| {label} | {f['draws']} x {f['samples']} | {f['mean']:.3f} | "
                         f"{f['std_one_sample']:.3f} | {p5:.3f} / {p50:.3f} / {p95:.3f} | "
                         f"{100 * f['share_of_draws_above_target']:.0f} % | "
                         f"{100 * f['share_of_samples_above_target']:.0f} % |")
        lines.append("")
    return "\n".join(lines)


def _noise_summary(floor: NoiseFloor) -> dict:
    per_statistic = {name: {"median": round(floor.quantile(name, 50), 3),
                            "p95": round(floor.quantile(name, 95), 3),
                            "share_above_target": round(floor.share_above(KS_TARGET, name), 3)}
                     for name in STATISTICS}
    return {"share_any_above_target": round(floor.share_above(KS_TARGET), 3),
            "statistics": per_statistic}


def noise_markdown(report: dict) -> str:
    lines = []
    for tier, row in report["noise"].items():
        copy, spec, perfect = (row[k] for k in ("copy_random_split", "copy_spec_split",
                                               "perfect_generator"))
        lines += [f"D3-{tier} ({row['boards']} boards, held-out half {row['held_out']}; "
                  f"{row['draws']} draws, 512 synthetic boards each): median / 95th percentile "
                  f"/ share of draws above {KS_TARGET}", "",
                  "| statistic | copy of the calibration half, random splits | copy, SPEC split "
                  "| perfect generator |", "|---|---:|---:|---:|"]
        for name in STATISTICS:
            cells = [_noise_cell(side["statistics"][name]) for side in (copy, spec, perfect)]
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
        lines.append("| any statistic | " + " | ".join(
            f"{100 * side['share_any_above_target']:.0f} %" for side in (copy, spec, perfect))
            + " |")
        lines.append("")
    return "\n".join(lines)


def _noise_cell(cell: dict) -> str:
    return (f"{cell['median']:.3f} / {cell['p95']:.3f} / "
            f"{100 * cell['share_above_target']:.0f} %")


# --- difficulty: the agent's CP @1 on both sides ---------------------------------------

def spread(items: list, count: int) -> list:
    """`count` items evenly spread over `items` (all of them if there are no more): the first
    N of a D3 tier would be its N smallest boards."""
    if len(items) <= count:
        return list(items)
    last = len(items) - 1
    return [items[round(i * last / (count - 1))] for i in range(count)]


def difficulty(args, d3_root: Path, tier: str) -> dict:
    """CP @1 of `args.agent` on `args.boards` synthetic boards (the split's first ones:
    synthetic boards are drawn independently) and as many of the tier's `full` split, spread
    over its table order. Runs and reports go under `args.work` (a rerun resumes)."""
    work = Path(args.work)
    real_ids = [b.board_id for b in spread(d3_tier_boards(d3_root, tier), args.boards)]
    ours = synthetic_boards(Path(args.synthetic), args.config, args.split, args.boards)
    sides = {"real": (d3_root, tier_config(tier), D3_SPLIT, real_ids),
             "synthetic": (Path(args.synthetic), args.config, args.split,
                           [b.board_id for b in ours])}
    out = {}
    for side, (root, config, split, ids) in sides.items():
        suffix = "" if args.drc == "step" else f"-drc-{args.drc}"
        runs = work / f"{side}-{config}-{args.agent}{suffix}"
        _rollouts(root, config, split, ids, args.agent, runs, args.workers, args.drc,
                  args.rollout_timeout)
        # the synthetic side's boards are the split's first ones: only they are scored
        out[side] = _cp_at1(root, config, split, ids, runs, work / f"{runs.name}-report",
                            args.workers, limit=len(ids) if side == "synthetic" else None)
        out[side].update(config=config, split=split)
    out.update(agent=args.agent, drc=args.drc)
    return out


def _rollouts(root: Path, config: str, split: str, board_ids: list[str], agent: str,
              runs: Path, workers: int, drc: str, timeout: float | None = None) -> None:
    """One rollout (seed 0) per board, as `pcbdata rollout` runs them, for chosen boards; a
    rollout past `timeout` seconds (default: the runner's) leaves no board, CP 0."""
    from pcbdata.env.registry import env_id_for
    from pcbdata.executors import resolve
    from pcbdata.runners.rollout import ROLLOUT_TIMEOUT, pending

    todo = pending(board_ids, 1, runs)
    env_kwargs = {"id": env_id_for(config), "config": config, "root": str(root.resolve()),
                  "split": split, "drc": drc}
    tasks = [(env_kwargs, agent, b, r, str(runs.resolve()), None) for b, r in todo]
    if not tasks:
        return
    with resolve(None).pool(workers=max(1, min(workers, len(tasks))),
                            task_timeout=timeout or ROLLOUT_TIMEOUT, tasks_per_worker=10**9,
                            memory_limit_mb=0) as pool:
        outcomes = pool.map("pcbdata.runners.rollout:rollout_task", tasks)
        errors = [_report_rollout(done, len(tasks), config, todo[outcome.index][0], outcome)
                  for done, outcome in enumerate(outcomes, 1)]
    if all(errors):
        raise SystemExit(f"bench_realism: every rollout on {config} failed: {errors[0]}")


def _report_rollout(done: int, total: int, config: str, board_id: str, outcome) -> str | None:
    """Prints one progress line; returns the error (None if the rollout ran)."""
    what = "ok" if outcome.ok else f"failed: {outcome.error}"
    print(f"  [{done}/{total}] {config} {board_id}: {what}", file=sys.stderr)
    return None if outcome.ok else str(outcome.error)


def _cp_at1(root: Path, config: str, split: str, board_ids: list[str], runs: Path,
            report: Path, workers: int, limit: int | None = None) -> dict:
    """Mean CP @1 over the chosen boards (`pcbdata eval`, of the split's first `limit` boards
    when given; boards not chosen have no rollout and are left out of the mean)."""
    from pcbdata.evaluator.runs import evaluate_set

    evaluate_set(root, config, split, report, runs=runs, k=1, workers=workers,
                 progress=False, limit=limit)
    with open(report / "per_board.csv", newline="", encoding="utf-8") as handle:
        rows = {r["board_id"]: r for r in csv.DictReader(handle)}
    cps = [float(rows[b]["cp"] or 0) for b in board_ids]
    return {"boards": len(cps), "cp_at1": sum(cps) / len(cps) if cps else None,
            "board_ids": board_ids}


def markdown(report: dict) -> str:
    tiers = list(report["ks"])
    half = report.get("half", "held-out").replace("-", " ")
    head = "| statistic | " + " | ".join(f"D3-{t} ({report['ks'][t]['boards']} {half})"
                                          for t in tiers) + " |"
    side = (f"`{report['config']}` ({report['synthetic_boards']} boards, split "
            f"`{report['split']}`)" if report["synthetic_boards"]
            else "each tier's calibration half"
            + (" with the dropped PCBench boards (weighted)" if report.get("extended") else ""))
    against = ("the calibration half and the tier-sized PCBench boards D3 dropped (weighted "
               "to its pads)" if half == "extended" else f"the {half} half")
    lines = [f"{side}: KS distance vs {against} (SPEC 2b's bound max(0.15, 1 % critical "
             f"value)); * above the bound", "", head,
             "|---|" + "---:|" * len(tiers)]
    for name in STATISTICS + NET_SHAPES:
        cells = [_cell(report["ks"][t]["distances"][name], report["ks"][t]["bound"][name])
                 for t in tiers]
        label = name + (" (all nets)" if name == PER_NET else "")
        label += " (per board; not SPEC 2b's)" if name in NET_SHAPES else ""
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    for tier, c in report.get("classifier", {}).items():
        top = sorted(c["importance"].items(), key=lambda kv: -kv[1])[:2]
        lines.append(f"\nD3-{tier} classifier test ({c['boards']} "
                     f"{c.get('half', 'held-out').replace('-', ' ')} boards vs "
                     f"{c['samples']} level samples): ROC AUC {c['auc_mean']:.3f} +- "
                     f"{c['auc_std']:.3f} (max {c['auc_max']:.3f}; target <= {c['target']}), "
                     f"real half vs real half {c['real_vs_real_auc']:.3f} (pads-interleaved "
                     f"halves, below 0.5; the floor: --noise --classifier); leans on "
                     + ", ".join(f"{n} ({v:.3f})" for n, v in top))
    for tier, side in report.get("difficulty", {}).items():
        real, ours = side["real"], side["synthetic"]
        lines.append(f"\n{side['agent']} CP @1: D3-{tier} ({real['boards']} boards of "
                     f"`{real['config']}/{real['split']}`) {_percent(real['cp_at1'])}, "
                     f"`{ours['config']}` ({ours['boards']} boards) {_percent(ours['cp_at1'])}")
    return "\n".join(lines) + "\n"


def _percent(cp: float | None) -> str:
    return "n/a" if cp is None else f"{100 * cp:.1f}"


def _cell(distance: float | None, bound: float | None) -> str:
    if distance is None:
        return "n/a"
    mark = "" if bound is None or distance <= bound else " *"
    return f"{distance:.3f}{mark} ({bound:.2f})"


def main(argv: list[str] | None = None) -> None:
    args = _parser().parse_args(argv)
    d3_root = Path(args.d3)
    if args.half == "extended" and not args.pcbench:
        raise SystemExit("bench_realism: --half extended needs --pcbench (a PCBench checkout)")
    external = _external(args, d3_root) if args.pcbench else None
    if args.write_targets:
        text = json.dumps(targets(d3_root, external), indent=1) + "\n"
        Path(args.write_targets).write_text(text)
        print(f"wrote {args.write_targets}")
        return
    start = time.perf_counter()
    report = {"machine": machine(), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
              "load_average": os.getloadavg(), "d3": str(d3_root)}
    if args.noise and args.classifier:
        draws = args.draws or 10
        report["classifier_noise"] = classifier_noise_table(d3_root, args.tier, draws,
                                                            args.samples)
        report["seconds"] = round(time.perf_counter() - start, 1)
        _write(args, report, classifier_noise_markdown(report))
        return
    if args.noise:
        report["noise"] = noise_table(d3_root, args.tier, args.draws or 1000)
        report["seconds"] = round(time.perf_counter() - start, 1)
        _write(args, report, noise_markdown(report))
        return
    if args.halves:
        report.update(config="calibration half", split="odd rows", synthetic_boards=0,
                      extended=args.half == "extended",
                      ks=ks_table(d3_root, args.tier, None, args.half, external))
    elif not args.synthetic or not args.config:
        raise SystemExit("bench_realism: give --synthetic and --config (or --halves, --noise or "
                         "--write-targets)")
    else:
        boards = synthetic_boards(Path(args.synthetic), args.config, args.split, args.limit)
        ours = measure(boards)
        report.update(config=args.config, split=args.split, synthetic_boards=len(boards),
                      half=args.half, ks=ks_table(d3_root, args.tier, ours, args.half,
                                                  external))
        if args.classifier:
            report["classifier"] = {tier: classifier_table(d3_root, tier, ours, args.samples,
                                                           args.half)
                                    for tier in args.tier}
    if args.difficulty and not args.halves:
        report["difficulty"] = {tier: difficulty(args, d3_root, tier) for tier in args.tier}
    report["seconds"] = round(time.perf_counter() - start, 1)
    _write(args, report, markdown(report))


def _external(args, d3_root: Path) -> dict:
    """Per tier, the dropped PCBench boards of its size (upgraded once into the work folder)."""
    tiers = list(TIERS) if args.write_targets else args.tier
    work = Path(args.external_work or Path(args.work) / "external")
    out = external_samples(d3_root, Path(args.pcbench), tiers, work, args.workers, _say)
    for tier, sample in out.items():
        failed = "; ".join(f"{name}: {why}" for name, why in sorted(sample.failures.items()))
        _say(f"D3-{tier}: {len(sample.boards)} dropped PCBench boards with "
             f"{sample.pad_range[0]}-{sample.pad_range[1]} terminal pads ({sample.outside} "
             f"outside, {len(sample.failures)} not measured{': ' + failed if failed else ''})")
    return out


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _write(args, report: dict, text: str) -> None:
    print(text)
    if args.md:
        Path(args.md).write_text(text)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--d3", required=True, help="a D3 build (pcbdata build d3 --out DIR)")
    parser.add_argument("--synthetic", help="a built synthetic set (pcbdata build ... --out DIR)")
    parser.add_argument("--config", help="the set's config to measure, e.g. d2r-b or d2")
    parser.add_argument("--split", default="train", help="its split (default: train)")
    parser.add_argument("--limit", type=int, help="only the first N synthetic boards")
    parser.add_argument("--tier", type=lambda s: s.upper().split(","), default=list(TIERS),
                        help="tiers to compare with, e.g. B or A,B,C (default: all)")
    parser.add_argument("--md", help="write the table as Markdown here")
    parser.add_argument("--json", help="write the whole report as JSON here")
    parser.add_argument("--half", choices=("held-out", "calibration", "extended"),
                        default="held-out",
                        help="the tier half to compare with (default: held-out, the SPEC's "
                             "measure; calibration shows what tuning reached; extended: the "
                             "calibration half and the dropped PCBench boards, --pcbench)")
    parser.add_argument("--pcbench", help="a PCBench checkout: adds the boards of each tier's "
                        "size that D3's revalidation dropped (--half extended, "
                        "--write-targets)")
    parser.add_argument("--external-work", help="where the dropped boards are upgraded and "
                        "kept (default: WORK/external; a rerun reuses them)")
    parser.add_argument("--halves", action="store_true",
                        help="compare each tier's calibration half with its held-out half "
                             "instead of a synthetic set (the distance sampling alone gives)")
    parser.add_argument("--noise", action="store_true",
                        help="the distances sampling alone gives on each tier: a copy of the "
                             "calibration half, and a generator drawing from the tier itself "
                             "(pcbdata.realism.noise); with --classifier, the classifier "
                             "test's AUC for such generators instead")
    parser.add_argument("--draws", type=int, help="simulated draws (--noise; default 1000, "
                        "with --classifier 10 splits of --samples level samples each)")
    parser.add_argument("--write-targets", metavar="PATH",
                        help="only write each tier's calibration-half summary (JSON)")
    parser.add_argument("--classifier", action="store_true",
                        help="also the joint test of SPEC 2b: a gradient-boosted classifier "
                             "telling held-out real boards from --samples level samples of as "
                             "many boards (10-fold ROC AUC; needs scikit-learn)")
    parser.add_argument("--samples", type=int, default=20,
                        help="disjoint level samples for --classifier (default 20)")
    parser.add_argument("--difficulty", action="store_true",
                        help="also the agent's CP @1 on the synthetic set vs the real tier")
    parser.add_argument("--agent", default="scripted-shove", help="agent for --difficulty")
    parser.add_argument("--boards", type=int, default=64, help="boards per side (--difficulty)")
    parser.add_argument("--rollout-timeout", type=float, metavar="SECONDS",
                        help="a rollout longer than this leaves no board and scores CP 0 "
                             "(--difficulty; default: the runner's 3600 s)")
    parser.add_argument("--drc", choices=("step", "terminal"), default="step",
                        help="the environment's DRC, as `pcbdata rollout --drc` (default: step)")
    parser.add_argument("--workers", type=int, default=2, help="rollout and eval workers")
    parser.add_argument("--work", default="/tmp/bench-realism",
                        help="runs and eval reports of --difficulty (kept: a rerun resumes)")
    return parser


if __name__ == "__main__":
    main()

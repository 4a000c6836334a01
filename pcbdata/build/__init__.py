"""Building board sets: what `pcbdata build` does, as library functions, and the pipelines.

Modules: `synthetic` (generated boards written with KiCad checks of a sample, resumable, and
their manifest), `reference` (router-found reference routings of generated boards, handed the
agent as a `ReferencePlan`), `progress` (progress lines), `d3` (the curated real-board set from
a PCBench checkout, with the rules of `pcbdata.curation`). This module is the facade: each
function assembles its configs from the registry (`pcbdata.sets.configs`), builds them and
publishes the folder.

    build_d1(out, grids=[10, 50], options=SyntheticOptions(splits=["test"]))
    build_level(out, "d2", level="hard", overrides={"min_pad_spacing_mm": 3.6})
    build_level(out, "d2r", "b")                                   # any family with levels
    build_configs(out, [get_config("d2"), get_config("d1-g10")])   # any registered configs
    build_d3(source, out)

The CLI modules (`pcbdata.cli.build_*`) only parse arguments, call one of these and print.
"""
from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pcbdata.build.reference import ReferencePlan
from pcbdata.build.synthetic import (
    BuildSummary,
    ConfigInfo,
    SplitJob,
    build_synthetic,
    check_sample,
    locked_root,
)
from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import output_folder
from pcbdata.executors import Executor, resolve
from pcbdata.sets.configs import SYNTHETIC_SPLITS, ConfigSpec, d1_config, level_config

Log = Callable[[str], None]
# Board ids have five digits (`board_00000` .. `board_99999`) and sort in index order only
# while they do.
MAX_COUNT = 100_000
# Each worker is a separate process (a KiCad one holds ~100 MB); more is a typo that would
# exhaust the machine's process table or memory before doing any work.
MAX_WORKERS = 1024


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


@dataclass
class SyntheticOptions:
    """Options of a synthetic build (D1, D2).

    `splits`: which splits (default: all); `seed`: base seed (default: the config's); `count`:
    boards per split instead of the preset's sizes (board i is the same whatever the count);
    `check_train`: train boards checked in KiCad, evenly spread (validation and test boards are
    always all checked); `check`: False skips the KiCad checks; `workers`: processes for
    generation and checks (default: all cores); `publish`: write the parquet shards, card and
    pictures at the end; `log`: where progress lines go (default: stderr); `executor`: where
    generation and checks run (`pcbdata.executors`: None or "local" for this machine's
    worker processes, `RayExecutor(address)` or "ray" for a Ray cluster; same bytes);
    `reference`: route each board of the plan's splits with a bundled agent and keep a clean
    rollout as its reference (`pcbdata.runners.reference.plan(...)`; None: no routing)."""

    splits: list[str] | None = None
    seed: int | None = None
    count: int | None = None
    check_train: int = 128
    check: bool = True
    workers: int | None = None
    publish: bool = True
    log: Log = _stderr
    executor: Executor | str | None = None
    reference: ReferencePlan | None = None

    def resolved_workers(self) -> int:
        return self.workers or os.cpu_count() or 1

    def validate(self) -> None:
        from pcbdata.core.rng import check_seed

        if self.count is not None and not 1 <= self.count <= MAX_COUNT:
            raise UserError(f"--count must be from 1 to {MAX_COUNT}, got {self.count}")
        if self.workers is not None and not 1 <= self.workers <= MAX_WORKERS:
            raise UserError(f"--workers must be from 1 to {MAX_WORKERS}, got {self.workers}")
        if self.check_train < 0:
            raise UserError(f"--check-train must be >= 0, got {self.check_train}")
        if self.seed is not None:
            check_seed(self.seed)
        for split in self.splits or ():
            if split not in SYNTHETIC_SPLITS:
                raise UserError(f"unknown split {split!r}; choose from "
                                f"{', '.join(SYNTHETIC_SPLITS)}")
        self._validate_reference()

    def _validate_reference(self) -> None:
        """Reference routing applies to splits being built; naming another is a mistake."""
        if self.reference is None or self.reference.splits is None:
            return
        built = self.splits or list(SYNTHETIC_SPLITS)
        missing = [s for s in self.reference.splits if s not in built]
        if missing:
            raise UserError(f"--reference-splits: {', '.join(missing)} is not among the splits "
                            f"being built ({', '.join(built)})")


def _jobs(spec: ConfigSpec, options: SyntheticOptions) -> list[SplitJob]:
    generator = spec.generator()
    wanted = options.splits or list(spec.splits)
    built = [s for s in spec.splits if s in wanted]
    routed = options.reference.routed_splits(built) if options.reference else []
    jobs = []
    for split in built:
        count = options.count or spec.sizes[split]
        checked = [] if not options.check else check_sample(
            count, options.check_train if split == "train" else None)
        jobs.append(SplitJob(spec.name, split, count, generator, checked,
                             reference=split in routed))
    return jobs


def _config_info(spec: ConfigSpec, options: SyntheticOptions) -> ConfigInfo:
    assert spec.seed is not None
    return ConfigInfo(family=spec.family, set_version=spec.version,
                      seed=spec.seed if options.seed is None else options.seed,
                      parameters=spec.parameters, extra=dict(spec.manifest))


def build_configs(out: str | Path, specs: list[ConfigSpec],
                  options: SyntheticOptions | None = None) -> BuildSummary:
    """Builds synthetic configs of the registry into `out` (then publishes it)."""
    options = options or SyntheticOptions()
    options.validate()
    for spec in specs:
        if not spec.synthetic:
            raise UserError(f"config {spec.name!r}: build D3 with build_d3 (`pcbdata build d3`)")
    jobs = [job for spec in specs for job in _jobs(spec, options)]
    configs = {spec.name: _config_info(spec, options) for spec in specs}
    output_folder(out)  # last check, first write: a refused run leaves nothing
    workers = options.resolved_workers()
    executor = resolve(options.executor)
    where = f"{workers} workers" if executor.name == "local" else f"executor {executor.name}"
    options.log(f"pcbdata build: {', '.join(sorted(configs))} -> {out} ({where})")
    if options.reference is not None:
        options.log(_reference_line(options.reference, jobs))
    with locked_root(out):  # a second build into the folder waits for this one
        summary = build_synthetic(out, jobs, configs, workers=workers, log=options.log,
                                  executor=executor, reference=options.reference)
        if options.publish:
            from pcbdata.publish import publish_set

            publish_set(out, list(configs))
    return summary


def _reference_line(plan: ReferencePlan, jobs: list[SplitJob]) -> str:
    routed = list(dict.fromkeys(job.split for job in jobs if job.reference))
    where = ", ".join(routed) if routed else \
        "no split (validation and test are routed unless --reference-splits names others)"
    return (f"reference routing: {plan.agent}, seeds 0..{plan.rollouts - 1}, splits: {where}")


def build_d1(out: str | Path, grids: list[int] | None = None, placement: str | None = None,
             options: SyntheticOptions | None = None) -> BuildSummary:
    """D1 at `grids` (default: the preset's) with `placement` (default: the preset's)."""
    from pcbdata.sets.presets import d1_preset

    specs = [d1_config(grid, placement) for grid in grids or d1_preset().grid_sizes]
    return build_configs(out, specs, options)


def build_level(out: str | Path, family: str, level: str | None = None,
                overrides: dict | None = None,
                options: SyntheticOptions | None = None,
                version: str | None = None) -> BuildSummary:
    """One level of a family with levels (`build_level(out, "d2", "hard")`, `build_level(out,
    "d2r", "b")`; default: the family's default level), with parameters overridden (`--set`)
    if any; `version`: an earlier version of the level, kept in the package (default: the
    current one)."""
    return build_configs(out, [level_config(family, level, overrides, version)], options)


def build_d3(source: str | Path, out: str | Path, recipe: str | Path | None = None,
             workers: int | None = None, tasks_per_worker: int = 20, log: Log | None = None,
             publish: bool = True, executor: Executor | str | None = None) -> dict:
    """D3 from a PCBench checkout at `source` with the recipe at `recipe` (default: the
    packaged one); returns the summary (fates, tier counts, wall seconds). The boards run on
    `executor` (default: this machine's workers; see `SyntheticOptions`)."""
    from pcbdata.build.d3 import build
    from pcbdata.sets.recipe import load_recipe

    if not os.path.isdir(source):
        raise UserError(f"{source}: no such folder")
    if workers is not None and not 1 <= workers <= MAX_WORKERS:
        raise UserError(f"--workers must be from 1 to {MAX_WORKERS}, got {workers}")
    if tasks_per_worker < 1:
        raise UserError("--tasks-per-worker must be at least 1")
    recipe_data = load_recipe(recipe)
    boards_dir = recipe_data.source.boards_dir
    if not os.path.isdir(os.path.join(source, boards_dir)):
        raise UserError(f"{source}: not a PCBench checkout (no {boards_dir}/ folder)")
    output_folder(out)  # last check, first write: a refused run leaves nothing
    from pcbdata.core.fsutil import folder_lock

    with folder_lock(out, "built"):  # a second build into the folder waits for this one
        summary = build(source, out, recipe_data,
                        workers=workers or min(os.cpu_count() or 1, MAX_WORKERS), log=log,
                        tasks_per_worker=tasks_per_worker, executor=resolve(executor))
        if publish:
            from pcbdata.publish import publish_set

            publish_set(out, sorted(summary["tiers"]))
    return summary

"""Real boards of a D3 tier's size that D3 itself does not hold: a second calibration sample.

SPEC 2b calibrates a level on its tier's odd rows and measures it on the even ones. On D3-A
those halves (50 boards each) are further apart than 0.15 in two statistics
(docs/realism.md, "How much of a distance is noise"), so a fit of the odd rows alone cannot
tell where the tier lies. PCBench holds more real boards of the same size: those D3's
revalidation dropped (DRC errors, or unconnected items) are real designs whose part counts,
outlines and pitches are as real as the kept ones'; only their copper broke a rule. This
module measures them, so a fit may use them beside the odd rows; the held-out half is never
touched.

A dropped board belongs to a tier's sample when its terminal pads lie in the tier's range
(the smallest and largest of the tier's boards). Boards are measured on KiCad 9's save of
them (`pcbdata.kicad.upgrade.upgraded_board`, in isolated workers), as D3's own boards are:
a legacy file read as text loses its arcs. Upgraded files are kept in a work folder, so a
run stopped halfway resumes; a board whose PCBench file is not the one D3's build saw (its
hash in `curation_report.csv`) is refused, not measured.

The dropped boards are no draw of the tier: their pads follow another law than the tier's
(which is cut by pads), so `pads_matched_weights` gives each a weight that brings them to the
calibration half's pads distribution; distances to the extended sample are weighted
(`board_statistics.ks_distance` with weights).
"""
from __future__ import annotations

import csv
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from pcbdata.core import tree
from pcbdata.core.fsutil import write_atomic
from pcbdata.core.hashing import sha256_file
from pcbdata.curation.corpus import DRC_FAILURE, NOT_CONNECTED
from pcbdata.kicad.pool import KicadPool
from pcbdata.realism.statistics import BoardStatistics, board_statistics
from pcbdata.sets.recipe import load_recipe

#: Fates of boards that loaded, upgraded and were checked, and failed only the check.
DROPPED_FATES = (DRC_FAILURE, NOT_CONNECTED)
UPGRADE_TASK = "pcbdata.kicad.upgrade:upgraded_board"
#: The seed of the UUIDs KiCad mints while upgrading (no statistic depends on them).
UPGRADE_SEED = 0
UPGRADED_FILE = tree.BOARD_FILE


@dataclass(frozen=True)
class ExternalBoard:
    name: str
    path: Path
    statistics: BoardStatistics


@dataclass
class ExternalSample:
    """The dropped boards of one tier's size, and what became of the others."""

    tier: str
    pad_range: tuple[int, int]
    boards: list[ExternalBoard] = field(default_factory=list)
    #: dropped boards measured whose terminal pads lie outside the tier's range
    outside: int = 0
    #: name -> why it could not be measured (missing, changed, KiCad failure)
    failures: dict[str, str] = field(default_factory=dict)

    @property
    def statistics(self) -> list[BoardStatistics]:
        return [b.statistics for b in self.boards]

    def weights(self, calibration: list[BoardStatistics]) -> list[float]:
        """`pads_matched_weights` of these boards against `calibration`."""
        return pads_matched_weights(calibration, self.statistics)


#: Pads bins of the weights: quantiles of the calibration half (quintiles: 10 boards a bin on
#: D3-A's 50).
WEIGHT_BINS = 5


def pads_matched_weights(calibration: list[BoardStatistics], external: list[BoardStatistics],
                         bins: int = WEIGHT_BINS) -> list[float]:
    """A weight per external board that gives the external sample the calibration half's
    distribution of terminal pads (a tier is cut by pads; the dropped boards' pads follow
    another law): bins at the calibration half's pads quantiles, a board's weight the bin's
    share of calibration boards over its share of external ones, scaled to sum to the
    number of external boards (0 outside every bin, or when no bin holds one)."""
    import numpy as np

    if not calibration or not external:
        return [0.0] * len(external)
    cal = np.array([s.pads for s in calibration], dtype=float)
    ext = np.array([s.pads for s in external], dtype=float)
    edges = np.unique(np.quantile(cal, np.linspace(0, 1, bins + 1)))
    if edges.size < 2:  # every calibration board has the same pads: one bin of one value
        edges = np.repeat(edges, 2)

    def shares(pads):
        index = np.clip(np.searchsorted(edges, pads, side="right") - 1, 0, edges.size - 2)
        inside = (pads >= edges[0]) & (pads <= edges[-1])
        counts = np.bincount(index[inside], minlength=edges.size - 1) / pads.size
        return index, inside, counts

    _, _, cal_share = shares(cal)
    index, inside, ext_share = shares(ext)
    raw = np.where(inside, cal_share[index] / np.where(ext_share[index] > 0,
                                                      ext_share[index], 1.0), 0.0)
    if raw.sum() == 0:
        return [0.0] * len(external)
    return [float(w) for w in raw * len(external) / raw.sum()]


def dropped_boards(d3_root: Path) -> dict[str, str]:
    """PCBench board name -> the source file's SHA-256 D3's build saw, for every board its
    revalidation dropped (from the build's `curation_report.csv`)."""
    path = Path(d3_root) / tree.CURATION_REPORT_CSV
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no curation report (is {d3_root} a D3 build?)")
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        missing = {"name", "fate"} - set(reader.fieldnames or ())
        if missing:
            columns = ", ".join(sorted(missing))
            raise ValueError(f"{path}: not a curation report (no column {columns})")
        return {row["name"]: row.get("source_board_sha256") or "" for row in reader
                if row["fate"] in DROPPED_FATES}


def tier_pad_range(d3_root: Path, tier: str) -> tuple[int, int]:
    """The fewest and most terminal pads of the tier's boards (`characteristics.csv`)."""
    path = Path(d3_root) / tree.CHARACTERISTICS_CSV
    with open(path, newline="", encoding="utf-8") as handle:
        pads = [int(row["pads"]) for row in csv.DictReader(handle) if row["tier"] == tier]
    if not pads:
        raise ValueError(f"{path}: no board of tier {tier}")
    return min(pads), max(pads)


def external_sample(d3_root: str | Path, pcbench_root: str | Path, tier: str,
                    work: str | Path, workers: int = 2,
                    progress: Callable[[str], None] | None = None) -> ExternalSample:
    """Upgrades (or reuses) every dropped board and keeps those of the tier's size."""
    return external_samples(d3_root, pcbench_root, [tier], work, workers, progress)[tier]


def external_samples(d3_root: str | Path, pcbench_root: str | Path, tiers: list[str],
                     work: str | Path, workers: int = 2,
                     progress: Callable[[str], None] | None = None
                     ) -> dict[str, ExternalSample]:
    """`external_sample` of several tiers, each dropped board upgraded and measured once."""
    d3_root = Path(d3_root)
    samples = {tier: ExternalSample(tier, tier_pad_range(d3_root, tier)) for tier in tiers}
    upgraded, failures = upgrade_dropped(d3_root, Path(pcbench_root), Path(work), workers,
                                         progress)
    measured = [(name, board_statistics(upgraded[name])) for name in sorted(upgraded)]
    for sample in samples.values():
        sample.failures = dict(failures)
        low, high = sample.pad_range
        for name, stats in measured:
            if low <= stats.pads <= high:
                sample.boards.append(ExternalBoard(name, upgraded[name], stats))
            else:
                sample.outside += 1
    return samples


def upgrade_dropped(d3_root: Path, pcbench_root: Path, work: Path, workers: int = 2,
                    progress: Callable[[str], None] | None = None
                    ) -> tuple[dict[str, Path], dict[str, str]]:
    """(name -> upgraded file, name -> failure) over every dropped board; files already in
    `work` are reused."""
    layout = load_recipe().source
    if not (pcbench_root / layout.boards_dir).is_dir():
        raise FileNotFoundError(f"{pcbench_root}: not a PCBench checkout (no "
                                f"{layout.boards_dir}/ folder)")
    done: dict[str, Path] = {}
    failures: dict[str, str] = {}
    todo: list[tuple[str, Path]] = []
    for name, sha in sorted(dropped_boards(d3_root).items()):
        source = pcbench_root / layout.boards_dir / name / layout.board_file
        target = work / name / UPGRADED_FILE
        if target.is_file():
            done[name] = target
        elif not source.is_file():
            failures[name] = f"{source}: missing"
        elif sha and sha256_file(source) != sha:
            failures[name] = f"{source}: not the file D3's build saw (SHA-256 differs)"
        else:
            todo.append((name, source))
    if todo:
        _upgrade(todo, work, workers, done, failures, progress)
    return done, failures


def _upgrade(todo: list[tuple[str, Path]], work: Path, workers: int, done: dict[str, Path],
             failures: dict[str, str], progress: Callable[[str], None] | None) -> None:
    with KicadPool(workers=max(1, min(workers, len(todo))), task_timeout=300) as pool:
        args = [(str(source), UPGRADE_SEED) for _, source in todo]
        for count, outcome in enumerate(pool.map(UPGRADE_TASK, args), start=1):
            name = todo[outcome.index][0]
            if outcome.ok:
                done[name] = work / name / UPGRADED_FILE
                write_atomic(done[name], outcome.value)
            else:
                failures[name] = outcome.error
            if progress and (count % 25 == 0 or count == len(todo)):
                progress(f"upgraded {count}/{len(todo)} dropped PCBench boards "
                         f"({len(failures)} failed)")


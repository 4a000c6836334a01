"""The environment's pad clusters (finish targets, ratsnest) are the evaluator's: on real
routed boards the labels per net count what the evaluator counts (one function,
`pcbdata.kicad.scoring.copper_labels`, over pads, tracks, vias and zones)."""
from __future__ import annotations

from pathlib import Path

from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, REFERENCE_FILE, RULES_FILE
from pcbdata.kicad.pool import KicadPool
from tests.helpers import skip_without_snapshot


def _references(root: Path) -> list[Path]:
    return sorted(p.parent for p in root.glob(f"d3-*/test/*/{REFERENCE_FILE}"))


def test_env_clusters_are_the_evaluators_on_routed_real_boards(d3_set):
    folders = _references(Path(d3_set))[:16]
    if not folders:
        skip_without_snapshot(f"{d3_set}: no D3 reference boards")
    jobs = [(str(f / REFERENCE_FILE), str(f / PROJECT_FILE),
             str(f / RULES_FILE) if (f / RULES_FILE).is_file() else None) for f in folders]
    with KicadPool(workers=2, task_timeout=300) as pool:
        outcomes = list(pool.map("tests.env.cluster_probe:env_and_evaluator_clusters", jobs))
    assert all(o.ok for o in outcomes), [o.error for o in outcomes if not o.ok]
    for outcome in outcomes:
        got = outcome.value
        assert got["snapshot"] == got["evaluator"], jobs[outcome.index][0]
        assert got["labels"] == got["evaluator"], jobs[outcome.index][0]
        assert sum(got["evaluator"].values()) > 0, jobs[outcome.index][0]


def test_snapshots_that_remember_links_and_records_are_the_fresh_ones(d3_set):
    """The environment's snapshot asks KiCad only about new items (`copper_labels` memory,
    remembered track records): laying a routed real board's copper again in batches, taking
    up every third track and pruning the rest, each snapshot's copper, clusters and totals
    are those worked out afresh; and the connectivity `apply` keeps up step by step gives the
    snapshot of one rebuilt from scratch."""
    folders = [f for f in _references(Path(d3_set)) if "/d3-b/" in f.as_posix()][:2]
    if not folders:
        skip_without_snapshot(f"{d3_set}: no D3-B reference boards")
    jobs = [(str(f / BOARD_FILE), str(f / PROJECT_FILE),
             str(f / RULES_FILE) if (f / RULES_FILE).is_file() else None,
             str(f / REFERENCE_FILE)) for f in folders]
    with KicadPool(workers=2, task_timeout=600) as pool:
        outcomes = list(pool.map("tests.env.snapshot_probe:snapshots_agree", jobs))
    assert all(o.ok for o in outcomes), [o.error for o in outcomes if not o.ok]
    for outcome in outcomes:
        got = outcome.value
        assert got["edits"] > 20 and got["compared"] > 10, (jobs[outcome.index][0], got)
        assert got["differ"] == [], (jobs[outcome.index][0], got)

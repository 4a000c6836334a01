"""Same bytes on Ray as locally: a D2 build (boards, manifest, parquet shards,
card) and the eval report of rollouts on it, run once with each executor."""
from __future__ import annotations

from pathlib import Path

import pytest

from pcbdata.executors import RayExecutor
from pcbdata.testing.drc import with_straight_tracks

REPORT_FILES = ("per_rollout.csv", "per_board.csv", "summary.json", "summary.md")


def _files(root: Path) -> dict[str, bytes]:
    """Every output file; the resumable logs under .pcbdata/ (appended in finishing order)
    are the driver's own state, not output."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and ".pcbdata" not in p.relative_to(root).parts}


def _build(out: Path, executor) -> dict[str, bytes]:
    from pcbdata.build import SyntheticOptions, build_level

    build_level(out, "d2", options=SyntheticOptions(splits=["test"], count=3, workers=2,
                                           log=lambda line: None, executor=executor))
    return _files(out)


def _rollouts(root: Path, runs: Path) -> None:
    """Two rollouts per board (straight tracks: shorts, clearance and unconnected items) and
    one cut file (a parse failure found before KiCad)."""
    from pcbdata.model.kicad_writer import board_files
    from pcbdata.sets.configs import get_config

    generator = get_config("d2").generator()
    for index in range(3):
        instance = generator.generate(get_config("d2").seed, "test", index)
        folder = runs / instance.board_id
        folder.mkdir(parents=True)
        text = board_files(with_straight_tracks(instance.board))["board.kicad_pcb"]
        (folder / "0.kicad_pcb").write_text(text)
        (folder / "0.json").write_text('{"time_s": 1.5}')
        routed = with_straight_tracks(instance.board, unrouted_every=2)
        (folder / "1.kicad_pcb").write_text(board_files(routed)["board.kicad_pcb"])
        (folder / "2.kicad_pcb").write_text(text[: len(text) // 2])
    assert (root / "manifest.json").is_file()


@pytest.mark.slow
def test_a_d2_build_and_its_eval_give_the_same_bytes_on_ray(ray_cluster, tmp_path):
    from pcbdata.evaluator.runs import evaluate_set

    local = _build(tmp_path / "local", None)
    on_ray = _build(tmp_path / "ray", RayExecutor())
    assert any(name.endswith(".parquet") for name in local)
    assert any(name.endswith("board.kicad_pcb") for name in local)
    assert on_ray.keys() == local.keys()
    assert [n for n in local if on_ray[n] != local[n]] == []

    _rollouts(tmp_path / "local", tmp_path / "runs")
    reports = {}
    for name, executor in (("local", None), ("ray", RayExecutor())):
        out = tmp_path / f"report-{name}"
        result = evaluate_set(tmp_path / "local", "d2", "test", out, runs=tmp_path / "runs",
                              k=3, workers=2, progress=False, executor=executor)
        assert result["summary"]["n_rollouts"] == 9
        reports[name] = {f: (out / f).read_bytes() for f in REPORT_FILES}
    statuses = {row["status"] for row in result["rollouts"]}
    assert statuses == {"ok", "parse_fail"}
    assert reports["ray"] == reports["local"]

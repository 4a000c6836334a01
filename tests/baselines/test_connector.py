"""Connector solutions (Jumanji's grid-action agents) to routed D1 boards, scored by the evaluator
with real KiCad; the Jumanji test rolls out Jumanji's own Connector on pcbdata's arrays."""
from __future__ import annotations

import csv
import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

from pcbdata.baselines import connector
from pcbdata.baselines.connector_jumanji import plan_paths
from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.evaluator.runs import evaluate_set

CONFIG, COUNT = "d1-g10", 8
HAVE_JUMANJI = importlib.util.find_spec("jumanji") is not None
_SEGMENT = re.compile(r"\(segment\s+\(start ([\d.]+) ([\d.]+)\)\s+\(end ([\d.]+) ([\d.]+)\)\s+"
                      r"\(width ([\d.]+)\)\s+\(layer \"([^\"]+)\"\)\s+\(net (\d+)\)")


@pytest.fixture(scope="module")
def d1_set(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("d1-connector")
    assert main(["build", "d1", "--grid", "10", "--splits", "test", "--count", str(COUNT),
                 "--no-check", "--workers", "1", "--out", str(root)]) == 0
    return root


def _arrays(root: Path) -> dict:
    with np.load(root / CONFIG / "test.npz") as data:
        return {name: data[name] for name in data.files}


def _board(root: Path, row: int) -> connector.BoardText:
    folder = root / CONFIG / "test" / f"board_{row:05d}"
    return connector.BoardText((folder / "board.kicad_pcb").read_text(), 10, str(folder))


def test_array_cells_are_the_pads_first_index_is_x(d1_set):
    arrays = _arrays(d1_set)
    asymmetric = 0
    for row in range(COUNT):
        board = _board(d1_set, row)
        for agent, (s, t) in enumerate(zip(arrays["starts"][row], arrays["targets"][row])):
            s, t = tuple(map(int, s)), tuple(map(int, t))
            assert board.nets[board.net_of(agent, s, t)] == f"NET{agent + 1}"
            assert board.centre(s) == (round((s[0] + 0.75) * 10e6), round((s[1] + 0.75) * 10e6))
            swapped = (s[::-1], t[::-1])
            if s[0] != s[1] and swapped[0] not in board.pad_nets:
                asymmetric += 1
                with pytest.raises(UserError, match="not the two pads of one net"):
                    board.net_of(agent, *swapped)
    assert asymmetric > 0  # a swap of x and y would have been caught


def _grid(size: int, trails: list[list], targets: list) -> np.ndarray:
    """A Connector grid in Jumanji's encoding: path 1 + 3a, head 2 + 3a, target 3 + 3a."""
    grid = np.zeros((size, size), dtype=np.int32)
    for agent, (trail, target) in enumerate(zip(trails, targets)):
        grid[target] = 3 + 3 * agent
        for cell in trail[:-1]:
            grid[cell] = 1 + 3 * agent
        grid[trail[-1]] = 2 + 3 * agent
    return grid


def test_grid_to_paths_reads_jumanji_encoding():
    u_turn = [(0, 0), (0, 1), (1, 1), (1, 0), (2, 0), (3, 0)]  # (1, 0) touches the start
    trails = [u_turn, [(4, 4)], [(0, 4), (1, 4), (2, 4)]]
    targets = [(3, 0), (4, 2), (3, 4)]
    grid = _grid(5, trails, targets)
    starts = [t[0] for t in trails]
    paths = connector.grid_to_paths(grid, starts, targets)
    assert paths[0] == [(0, 0), (1, 0), (2, 0), (3, 0)]  # the shorter walk through its cells
    assert paths[1] == [(4, 4)] and paths[2] == [(0, 4), (1, 4), (2, 4)]
    assert connector.corners([(0, 0), (0, 1), (0, 2), (1, 2), (2, 2)]) == [(0, 0), (0, 2),
                                                                            (2, 2)]
    broken = grid.copy()
    broken[1, 4] = 0
    with pytest.raises(UserError, match="agent 2's head .* is not joined"):
        connector.grid_to_paths(broken, starts, targets)
    with pytest.raises(UserError, match="agent 1's start cell"):
        connector.grid_to_paths(grid, [starts[0], (0, 3), starts[2]], targets)


def _padded(paths_per_board: list[list[list]], length: int) -> np.ndarray:
    out = np.full((len(paths_per_board), 5, length, 2), -1, dtype=np.int32)
    for b, paths in enumerate(paths_per_board):
        for a, path in enumerate(paths):
            out[b, a, : len(path)] = path
    return out


def _score(root: Path, runs: Path, out: Path) -> tuple[dict, list[dict]]:
    result = evaluate_set(root, CONFIG, "test", out, runs=runs, k=1, workers=2, progress=False)
    with open(out / "per_rollout.csv", newline="") as handle:
        return result["summary"], list(csv.DictReader(handle))


def test_cell_paths_become_tracks_the_evaluator_scores(d1_set, tmp_path):
    arrays = _arrays(d1_set)
    empty = np.zeros((10, 10), dtype=np.int32)
    plans = []
    for starts, targets in zip(arrays["starts"], arrays["targets"]):
        grid = empty.copy()
        for a, (s, t) in enumerate(zip(starts, targets)):
            grid[tuple(s)], grid[tuple(t)] = 2 + 3 * a, 3 + 3 * a
        plans.append(plan_paths(grid, starts, targets))
    np.savez(tmp_path / "paths.npz", paths=_padded(plans, 100), time_s=np.full(COUNT, 0.5))
    runs = tmp_path / "runs"
    counts = connector.convert_rollouts(d1_set, CONFIG, "test", tmp_path / "paths.npz", runs)
    assert counts["boards"] == counts["rollouts"] == COUNT and counts["agents"] == 5 * COUNT
    text = (runs / "board_00000" / "0.kicad_pcb").read_text()
    segments = _SEGMENT.findall(text)
    runs_in_plans = sum(len(connector.corners(p)) - 1 for p in plans[0] if len(p) > 1)
    assert len(segments) == runs_in_plans > 0
    assert {(w, layer) for *_, w, layer, _ in segments} == {("5", "F.Cu")}
    summary, rows = _score(d1_set, runs, tmp_path / "report")
    assert {r["status"] for r in rows} == {"ok"}
    assert summary["rout"] == pytest.approx(counts["connected"] / counts["agents"])
    assert summary["rout"] > 0.5 and summary["time"] == pytest.approx(0.5)
    connected = [sum(connector._connected(p, s, t) for p, s, t in zip(plan, ss, ts))
                 for plan, ss, ts in zip(plans, arrays["starts"], arrays["targets"])]
    for row in rows:
        board = int(row["board_id"].split("_")[1])
        assert float(row["rout"]) == pytest.approx(connected[board] / 5)
        assert int(row["drv"]) == 5 - connected[board]  # the open nets, nothing else


def test_bad_solutions_write_nothing(d1_set, tmp_path):
    paths = np.full((2, 5, 3, 2), -1, dtype=np.int32)
    paths[1, 0, :2] = [[0, 0], [1, 1]]
    np.savez(tmp_path / "bad.npz", paths=paths)
    with pytest.raises(UserError, match="jumps from"):
        connector.convert_rollouts(d1_set, CONFIG, "test", tmp_path / "bad.npz",
                                   tmp_path / "runs")
    assert not (tmp_path / "runs").exists()
    start = _arrays(d1_set)["starts"][0, 0]
    paths[0, 0, :2] = [start[0] + 1 - 2 * (start[0] == 9), start[1]], start
    np.savez(tmp_path / "bad.npz", paths=paths)
    with pytest.raises(UserError, match="agent 0's path begins at"):
        connector.convert_rollouts(d1_set, CONFIG, "test", tmp_path / "bad.npz",
                                   tmp_path / "runs")
    np.savez(tmp_path / "none.npz", time_s=np.zeros(2))
    assert main(["convert-connector", str(d1_set), "--config", CONFIG, "--solutions",
                 str(tmp_path / "none.npz"), "--out", str(tmp_path / "runs")]) == 2


@pytest.mark.skipif(not HAVE_JUMANJI, reason="jumanji is not installed (pip install "
                    "'pcbdata[jumanji]'); the converter tests above still run")
def test_jumanji_connector_rollouts_score_as_jumanji_counts(d1_set, tmp_path):
    from pcbdata.baselines.connector_jumanji import rollout_split

    result = rollout_split(d1_set, CONFIG, "test")
    ratio = result.pop("ratio_connections")
    np.savez(tmp_path / "grids.npz", **result)
    runs = tmp_path / "runs"
    assert main(["convert-connector", str(d1_set), "--config", CONFIG, "--solutions",
                 str(tmp_path / "grids.npz"), "--out", str(runs)]) == 0
    summary, rows = _score(d1_set, runs, tmp_path / "report")
    assert {r["status"] for r in rows} == {"ok"}
    assert summary["rout"] == pytest.approx(float(np.mean(ratio)))
    assert summary["rout"] > 0.6
    by_board = {r["board_id"]: float(r["rout"]) for r in rows}
    for board_id, share in zip(result["board_ids"], ratio):
        assert by_board[str(board_id)] == pytest.approx(float(share))


def test_grids_with_rollout_axis_match_the_same_paths(d1_set, tmp_path):
    arrays = _arrays(d1_set)
    starts, targets = arrays["starts"][:2], arrays["targets"][:2]
    plans, grids = [], []
    for ss, ts in zip(starts, targets):
        empty = np.zeros((10, 10), dtype=np.int32)
        for a, (s, t) in enumerate(zip(ss, ts)):
            empty[tuple(s)], empty[tuple(t)] = 2 + 3 * a, 3 + 3 * a
        plan = plan_paths(empty, ss, ts)
        plans.append(plan)
        grids.append(_grid(10, plan, [tuple(t) for t in ts]))
    np.savez(tmp_path / "grids.npz", grids=np.stack([grids, grids], axis=1),
             board_ids=arrays["board_ids"][:2], time_s=[[1.0, 2.0], [3.0, 4.0]])
    np.savez(tmp_path / "paths.npz", paths=_padded(plans, 100))
    connector.convert_rollouts(d1_set, CONFIG, "test", tmp_path / "grids.npz", tmp_path / "g")
    connector.convert_rollouts(d1_set, CONFIG, "test", tmp_path / "paths.npz", tmp_path / "p")
    for board in ("board_00000", "board_00001"):
        from_paths = _SEGMENT.findall((tmp_path / "p" / board / "0.kicad_pcb").read_text())
        for k in (0, 1):
            text = (tmp_path / "g" / board / f"{k}.kicad_pcb").read_text()
            assert _SEGMENT.findall(text) == from_paths
        assert not (tmp_path / "p" / board / "0.json").exists()
    assert '"time_s": 4.0' in (tmp_path / "g" / "board_00001" / "1.json").read_text()

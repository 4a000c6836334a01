"""Connector arrays of a D1 split (`<config>/<split>.npz`) for grid-action baselines.

Layout (Jumanji Connector / Mava): `starts`, `targets` int32 [N, num_agents, 2] hold cell
coordinates (i, j) of each net's two pads, where the pad of cell (i, j) is centred at
((i + 0.75) g, (j + 0.75) g) mm on the board: the first coordinate is the row index of the array
grid and the board's x axis. `board_ids` (unicode) gives the board of each row.

The archive is written with fixed zip timestamps so the same boards give the same bytes.
"""
from __future__ import annotations

import io
import zipfile

import numpy as np


def connector_arrays(board_ids: list[str], cells: list, grid: int, version: str) -> dict:
    pins = np.asarray(cells, dtype=np.int32).reshape(len(board_ids), -1, 2, 2)
    return {
        "starts": np.ascontiguousarray(pins[:, :, 0, :]),
        "targets": np.ascontiguousarray(pins[:, :, 1, :]),
        "board_ids": np.asarray(board_ids, dtype=str),
        "grid_size": np.asarray(grid, dtype=np.int32),
        "num_agents": np.asarray(pins.shape[1], dtype=np.int32),
        "connector_version": np.asarray(version, dtype=str),
    }


def npz_bytes(arrays: dict) -> bytes:
    """An `.npz` (readable by `numpy.load`) with deterministic bytes."""
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name in sorted(arrays):
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, np.asanyarray(arrays[name]), allow_pickle=False)
            archive.writestr(info, buffer.getvalue())
    return out.getvalue()

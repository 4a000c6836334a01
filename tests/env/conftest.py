"""Fixtures of the environment tests: tiny board sets written from the generators (the same
boards `pcbdata build` writes), and environments over them."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from pcbdata.testing.sets import write_set

D2_BOARDS = 4
D1_BOARDS = 2


@pytest.fixture(scope="session")
def board_set(tmp_path_factory) -> Path:
    """A set folder with d2/test (4 boards) and d1-g10/test (2 boards)."""
    root = tmp_path_factory.mktemp("env-set")
    write_set(root, "d2", "test", D2_BOARDS)
    write_set(root, "d1-g10", "test", D1_BOARDS)
    return root


@pytest.fixture(scope="session")
def d3_set(request) -> Path:
    """A built D3 set: the one PCBDATA_D3_SET names (`pcbdata build d3` output), else the real
    subset the curation tests build from the PCBench snapshot (skips without the snapshot)."""
    path = os.environ.get("PCBDATA_D3_SET")
    if path and Path(path).is_dir():
        return Path(path)
    return request.getfixturevalue("real_subset")["out"]


@pytest.fixture
def make_env(board_set):
    """gym.make over the tiny set; every environment made is closed after the test."""
    import gymnasium as gym

    import pcbdata.env  # noqa: F401
    made = []

    def factory(config: str = "d2", **options):
        options.setdefault("root", str(board_set))
        env = gym.make(f"pcbdata/Route-{config}-v2", **options)
        made.append(env)
        return env

    yield factory
    for env in made:
        env.close()

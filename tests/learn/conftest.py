from __future__ import annotations

from pathlib import Path

import pytest

from pcbdata.testing.sets import write_set

LEARN_BOARDS = 8


@pytest.fixture(scope="session")
def learn_set(tmp_path_factory) -> Path:
    """A set folder with d2/test (8 boards) for the shipped policy's rollouts."""
    root = tmp_path_factory.mktemp("learn-set")
    write_set(root, "d2", "test", LEARN_BOARDS)
    return root

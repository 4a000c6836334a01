from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the hand-made boards of boards.py


@pytest.fixture(scope="module")
def evaluator(kicad_pool):
    from pcbdata.evaluator import Evaluator

    with Evaluator(pool=kicad_pool) as ev:
        yield ev

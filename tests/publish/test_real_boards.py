"""The real board beside each D2R level on its card: shipped pictures and attribution for every
tier a level names, redrawn from D3 byte for byte, refused from another D3 build, and added to
a set published before cards had it."""
from __future__ import annotations

import hashlib
import json
import shutil

import pytest

from pcbdata.board_render import PANEL_SIZE
from pcbdata.cli import main
from pcbdata.core.errors import UserError
from pcbdata.core.tree import BOARD_FILE, board_dir
from pcbdata.publish.real_boards import (
    draw_real_boards,
    real_boards,
    real_picture,
    tier_real_board,
)
from pcbdata.resources import resource_path
from pcbdata.sets.presets import levels
from tests.helpers import skip_without_snapshot


def test_every_level_has_its_tiers_real_board_with_attribution():
    boards = real_boards()
    for name, level in levels("d2r").items():
        board = tier_real_board({"family": "d2r", "level": name})
        assert board is not None and board.tier == level["tier"]
        assert board == boards[level["tier"]]
        assert board.licence and board.author and board.source_repository.startswith("https://")
        assert board.board_id in board.caption() and board.licence in board.caption()
        width, height = PANEL_SIZE
        assert real_picture(board).shape == (height + 14, width, 3)  # a title bar above


def test_only_d2r_levels_have_a_real_board_beside():
    assert tier_real_board({"family": "d2", "level": "default"}) is None
    assert tier_real_board({"family": "d3", "tier": "A"}) is None
    assert tier_real_board({"family": "d2r", "level": "no-such-level"}) is None


def test_the_shipped_picture_is_the_one_drawn_from_the_d3_board(real_subset, kicad_pool,
                                                                 tmp_path):
    board = real_boards()["A"]
    d3 = real_subset["out"]
    path = board_dir(d3, "d3-a", "full", board.board_id) / BOARD_FILE
    if not path.is_file():
        skip_without_snapshot(f"{board.board_id} is not in the CI subset of PCBench")
    assert hashlib.sha256(path.read_bytes()).hexdigest() == board.board_sha256
    written = draw_real_boards(d3, tmp_path / "out", kicad_pool, tiers=["A"])
    shipped = resource_path("real_boards", board.picture_name).read_bytes()
    assert [p.name for p in written] == ["d3-a.png"] and written[0].read_bytes() == shipped

    other = tmp_path / "other"
    copy = board_dir(other, "d3-a", "full", board.board_id)
    shutil.copytree(path.parent, copy)
    (copy / BOARD_FILE).write_text(path.read_text() + "\n")
    with pytest.raises(UserError, match="another D3 build"):
        draw_real_boards(other, tmp_path / "out2", kicad_pool, tiers=["A"])
    with pytest.raises(UserError, match="missing"):
        draw_real_boards(tmp_path / "empty", tmp_path / "out3", kicad_pool, tiers=["A"])


def test_a_set_published_before_the_real_board_beside_gets_it_when_published_again(tmp_path):
    root = tmp_path / "set"
    assert main(["build", "d2r", "--level", "b", "--splits", "test", "--count", "3",
                 "--no-check", "--workers", "1", "--out", str(root)]) == 0
    beside = "pictures/d2r-b/beside-d3-b.svg"
    state = json.loads((root / "publish.json").read_text())
    assert beside in state["configs"]["d2r-b"]["pictures"]
    # As a publish before cards had it left the set: neither in the state nor on disk.
    state["configs"]["d2r-b"]["pictures"].remove(beside)
    (root / "publish.json").write_text(json.dumps(state))
    (root / beside).unlink()
    assert main(["publish", str(root)]) == 0
    assert (root / beside).is_file() and beside in (root / "README.md").read_text()
    assert main(["verify", str(root)]) == 0

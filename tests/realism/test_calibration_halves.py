"""The realism halves stay the boards they were (SPEC 2b's calibration on odd rows, held out
on even ones, of the D3 1.0.0 table): shipped by name, so D3's later rows (boards gained,
one lost) do not flip the parity of the rest."""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

from pcbdata.resources import resource_path

ROOT = Path(__file__).resolve().parents[2]


def _bench_realism():
    spec = importlib.util.spec_from_file_location("bench_realism",
                                                  ROOT / "bench" / "bench_realism.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    sys.modules["bench_realism"] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_shipped_calibration_halves():
    data = json.loads(resource_path("realism", "calibration.json").read_text())
    tiers = data["tiers"]
    assert {t: len(names) for t, names in tiers.items()} == {"A": 50, "B": 142, "C": 144}
    assert "hackaday_esp-14_power_meter__autosave-esp-14" not in tiers["B"]  # it left D3
    restored = {"Kefersender_UKW TX", "LiPoSensor_lipo_sensor", "MicroMaple_MicroMaple",
                "RGBMatrixPanelCPLD-PhotonBackpack_RGBMatrixPanel_CPLD"}
    assert not restored & set(tiers["C"])  # boards D3 gained join the held-out half


def test_halves_split_a_tier_by_name():
    bench = _bench_realism()
    names = sorted(bench.calibration_names("A"))[:3]
    boards = [bench.Board(f"{i:04d}_{n}", Path(n)) for i, n in
              enumerate(["new-board", *names, "other"], start=1)]
    calibration, held_out = bench.halves(boards, "A")
    assert [b.board_id[5:] for b in calibration] == names
    assert [b.board_id[5:] for b in held_out] == ["new-board", "other"]


def test_spec_bound_and_classifier_on_plain_samples():
    """SPEC 2b's per-statistic bound, and the classifier test: two draws of one population are
    not told apart (AUC near 0.5), a shifted one is (AUC near 1), on made-up statistics."""
    import random

    import pytest

    pytest.importorskip("sklearn", reason="the classifier test needs scikit-learn "
                                          "(pip install 'pcbdata[realism]')")
    from pcbdata.realism.statistics import STATISTICS

    bench = _bench_realism()
    assert bench.spec_bound(2000, 50) == pytest.approx(0.233, abs=1e-3)
    assert bench.spec_bound(2000, 143) == 0.15  # 0.142 < 0.15
    rng = random.Random(0)

    def board(shift: float):
        return type("S", (), {n: rng.gauss(10 + shift, 2) for n in STATISTICS})()

    same = bench.classifier_auc([board(0) for _ in range(120)], [board(0) for _ in range(120)])
    apart = bench.classifier_auc([board(0) for _ in range(120)], [board(4) for _ in range(120)])
    assert same[0] < 0.65 < 0.95 < apart[0]
    assert set(apart[1]) == set(STATISTICS)

"""The compiled clearance test (`pcbdata.router.clearance_kernel`) gives the reference form's
answers: on random segments against every kind of core, on segments placed exactly at their
allowed distance, and (tests/env/test_negotiated.py) as whole plans of real boards."""
from __future__ import annotations

import numpy as np
import pytest

from pcbdata.router import clearance_kernel
from pcbdata.router.geometry import BoardGeometry, CopperItem
from pcbdata.router.walkaround import WalkaroundRouter

MM = 1_000_000
OUTLINE = (((0, 0), (40 * MM, 0), (40 * MM, 30 * MM), (0, 30 * MM)),)

needs_numba = pytest.mark.skipif(clearance_kernel.numba is None,
                                 reason="numba is not installed (scripts/setup.sh installs it)")


def _board(rng: np.random.Generator) -> BoardGeometry:
    """Pads (rectangles, rotated octagons), a U-shaped zone, tracks, arcs and vias
    of three nets on two layers."""
    items = []
    for k in range(60):
        net = ("A", "B", "")[k % 3]
        layers = (("F.Cu",), ("B.Cu",), ("F.Cu", "B.Cu"))[k % 3]
        x, y = rng.uniform(2, 38) * MM, rng.uniform(2, 28) * MM
        kind = k % 5
        if kind == 0:
            w, h = rng.uniform(0.2, 2) * MM, rng.uniform(0.2, 2) * MM
            ring = ((x, y), (x + w, y), (x + w, y + h), (x, y + h))
            items.append(CopperItem("pad", net, layers, polygon=tuple(
                (round(a), round(b)) for a, b in ring), clearance=150_000))
        elif kind == 1:
            r = rng.uniform(0.2, 1.2) * MM
            ring = tuple((round(x + r * np.cos(t)), round(y + r * np.sin(t)))
                         for t in np.linspace(0, 2 * np.pi, 9)[:-1] + 0.3)
            items.append(CopperItem("pad", net, layers, polygon=ring))
        elif kind == 2:
            dx, dy = rng.uniform(-5, 5, 2) * MM
            items.append(CopperItem("track", net, layers[:1], start=(round(x), round(y)),
                                    end=(round(x + dx), round(y + dy)), width=250_000))
        elif kind == 3:
            items.append(CopperItem("via", net, ("F.Cu", "B.Cu"), start=(round(x), round(y)),
                                    end=(round(x), round(y)), width=600_000))
        else:
            items.append(CopperItem("arc", net, layers[:1], start=(round(x), round(y)),
                                    mid=(round(x + 1 * MM), round(y + 0.6 * MM)),
                                    end=(round(x + 2 * MM), round(y)), width=200_000))
    # a concave area: a U-shaped zone (segments inside its notch are outside it)
    items.append(CopperItem("zone", "", ("F.Cu",), polygon=(
        (20 * MM, 10 * MM), (30 * MM, 10 * MM), (30 * MM, 20 * MM), (27 * MM, 20 * MM),
        (27 * MM, 13 * MM), (23 * MM, 13 * MM), (23 * MM, 20 * MM), (20 * MM, 20 * MM))))
    return BoardGeometry(OUTLINE, tuple(items), edge_clearance=300_000)


def _segments(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.uniform(0, 40 * MM, (n, 2)).round()
    b = a + rng.normal(0, 4 * MM, (n, 2)).round()
    b[: n // 8] = a[: n // 8]  # dots
    return np.stack([a, b], axis=1)


@needs_numba
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_and_reference_answers_agree_on_random_segments(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    router = WalkaroundRouter(_board(rng))
    segments = _segments(rng, 3000)
    checked = 0
    for net in ("A", "B"):
        for layer in ("F.Cu", "B.Cu"):
            rules = router._rules(net, layer, 200_000, 150_000)
            monkeypatch.setenv("PCBDATA_NO_NUMBA", "1")
            reference = rules.failing(segments)
            monkeypatch.setenv("PCBDATA_NO_NUMBA", "0")
            assert clearance_kernel.enabled()
            compiled = rules.failing(segments)
            assert (compiled == reference).all(), np.flatnonzero(compiled != reference)
            status = rules.layer.grid.judge(segments, rules.need, rules.max_need)
            assert set(np.unique(status)) <= {0, 1}  # random segments are never borderline
            checked += int(reference.sum())
    assert 0 < checked < 4 * len(segments)  # both answers occur


@needs_numba
def test_a_segment_at_its_allowed_distance_is_left_to_the_reference(monkeypatch):
    """A track whose edge meets the other copper's exactly at the clearance: the compiled test
    calls it unsure, the reference decides, and a nanometre either side is sure."""
    pad = CopperItem("pad", "B", ("F.Cu",), polygon=((10 * MM, 10 * MM), (12 * MM, 10 * MM),
                                                      (12 * MM, 12 * MM), (10 * MM, 12 * MM)))
    router = WalkaroundRouter(BoardGeometry(OUTLINE, (pad,), edge_clearance=0))
    rules = router._rules("A", "F.Cu", 200_000, 150_000)
    need = 100_000 + 150_000  # half width + clearance
    y = 12 * MM + need
    segments = np.array([[[5 * MM, y - 1e-3], [20 * MM, y - 1e-3]],
                         [[5 * MM, y - 1.0], [20 * MM, y - 1.0]],
                         [[5 * MM, y + 1.0], [20 * MM, y + 1.0]]])
    status = rules.layer.grid.judge(segments, rules.need, rules.max_need)
    assert status.tolist() == [2, 1, 0]
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "1")
    reference = rules.failing(segments)
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "0")
    assert rules.failing(segments).tolist() == reference.tolist()
    assert reference.tolist()[1:] == [True, False]


@needs_numba
def test_soft_copper_owners_agree(monkeypatch):
    """The (segment, owner) pairs a priced search pays for are the same by either form."""
    from pcbdata.router.soft import SoftCopper, SoftLayer

    rng = np.random.default_rng(7)
    board = _board(rng)
    router = WalkaroundRouter(BoardGeometry(OUTLINE, (), edge_clearance=300_000))
    soft = SoftCopper(items=board.copper, owners=tuple(k % 7 for k in range(len(board.copper))),
                      prices={k: 1_000_000.0 * (k + 1) for k in range(7)})
    layer = SoftLayer(router, soft, "A", "F.Cu", 200_000, 150_000)
    segments = _segments(rng, 2000)
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "1")
    reference = layer.owners(segments), layer.prices(segments)
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "0")
    compiled = layer.owners(segments), layer.prices(segments)
    assert len(reference[0][0]) > 100
    for a, b in zip(reference[0], compiled[0]):
        assert a.tolist() == b.tolist()
    assert reference[1].tolist() == compiled[1].tolist()


@needs_numba
def test_ray_bounds_agree(monkeypatch):
    """The ray screen's bounds (how far a track may run before it certainly fails) by either
    form, within float rounding."""
    rng = np.random.default_rng(3)
    router = WalkaroundRouter(_board(rng))
    rules = router._rules("A", "F.Cu", 200_000, 150_000)
    points = rng.uniform(0, 40 * MM, (4000, 2))
    headings = rng.integers(0, 8, 4000)
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "1")
    rules._screen = None
    reference = rules.free(points, headings, 60 * MM)
    monkeypatch.setenv("PCBDATA_NO_NUMBA", "0")
    rules._screen = None
    compiled = rules.free(points, headings, 60 * MM)
    assert (np.isinf(reference) == np.isinf(compiled)).all()
    finite = np.isfinite(reference)
    assert finite.sum() > 1000 and (reference == 0).sum() > 10
    assert np.allclose(reference[finite], compiled[finite], rtol=0, atol=1e-6)

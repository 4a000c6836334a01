"""freeroute's pad model: it reads an oval pad (a Specctra `path`) as the box of
its end points without the width, and never turns a pad with its component or pin, so it ran
tracks through oval through-hole pads and turned rectangles. `exact_pads` rewrites the DSN
so that what freeroute reads holds every pad; the real-board test checks that against KiCad's
own pad shapes."""
from __future__ import annotations

import math
import re

import pytest
import shapely

from pcbdata.core.sexpr_text import block_end
from pcbdata.kicad.specctra_pads import exact_pads
from pcbdata.kicad.specctra_text import flip_back_components

DSN = """(pcb x
  (resolution um 10)
  (unit um)
  (placement
    (component Conn
      (place J1 10000 -20000 front 0)
      (place J2 30000 -20000 front 90)
      (place J3 50000 -20000 back 90)
    )
    (component "Lib:Chip"
      (place U1 70000 -20000 front 0)
      (place U2 90000 -20000 back 270)
    )
  )
  (library
    (image Conn
      (pin Oval[A]Pad_1700x2550_um 1 0 0)
      (pin Oval[A]Pad_2000x2000_um 2 2540 0)
      (pin Rect[A]Pad_1700x1700_um 3 5080 0)
    )
    (image "Lib:Chip"
      (pin Rect[T]Pad_1500x600_um 1 -1000 500)
      (pin Rect[T]Pad_1500x600_um (rotate 90) 2 1000 -500)
    )
    (padstack Oval[A]Pad_1700x2550_um
      (shape (path F.Cu 1700  0 -425  0 425))
      (shape (path B.Cu 1700  0 -425  0 425))
      (attach off)
    )
    (padstack Oval[A]Pad_2000x2000_um
      (shape (path F.Cu 2000  0 0  0 0))
      (shape (path B.Cu 2000  0 0  0 0))
      (attach off)
    )
    (padstack Rect[A]Pad_1700x1700_um
      (shape (rect F.Cu -850 -850 850 850))
      (shape (rect B.Cu -850 -850 850 850))
      (attach off)
    )
    (padstack Rect[T]Pad_1500x600_um
      (shape (rect F.Cu -750 -300 750 300))
      (attach off)
    )
    (padstack "Via[0-1]_600:400_um"
      (shape (circle F.Cu 600))
      (shape (circle B.Cu 600))
      (attach off)
    )
  )
)
"""
NAME = r'("(?:[^"\\]|\\.)*"|[^\s()]+)'


def _blocks(text: str, kind: str) -> dict[str, str]:
    return {m.group(1): text[m.start():block_end(text, m.start())]
            for m in re.finditer(r"\(" + kind + r"\s+" + NAME, text)}


def _shapes(block: str) -> list[tuple[str, list[float]]]:
    return [(m.group(1), [float(v) for v in m.group(2).split()])
            for m in re.finditer(r"\(shape\s+\((rect|circle|polygon|path)\s+\S+\s+([^()]*)\)",
                                 block)]


def _pins(dsn: str):
    """(ref, pin name, place x, y, side, rotation, pin x, y, own rotation, padstack block) for
    every placed pin."""
    images, stacks = _blocks(dsn, "image"), _blocks(dsn, "padstack")
    for image, block in _blocks(dsn, "component").items():
        for place in re.finditer(r"\(place\s+(\S+)\s+(\S+)\s+(\S+)\s+(front|back)\s+([^\s)]+)",
                                 block):
            ref, x, y, side, rotation = place.groups()
            for pin in re.finditer(r"\(pin\s+" + NAME + r"((?:\s+\(rotate\s+\S+\))?)\s+(\S+)"
                                   r"\s+(\S+)\s+(\S+)\)", images[image]):
                stack, own, name, px, py = pin.groups()
                own_angle = float(own.split()[-1].rstrip(")")) if own.strip() else 0.0
                yield (ref, name, float(x), float(y), side, float(rotation), float(px),
                       float(py), own_angle, stacks[stack])


def _turn(x: float, y: float, angle: float) -> tuple[float, float]:
    a = math.radians(angle)
    return x * math.cos(a) - y * math.sin(a), x * math.sin(a) + y * math.cos(a)


def _location(pin) -> tuple[float, float]:
    _, _, x, y, side, rotation, px, py, _, _ = pin
    dx, dy = _turn(-px if side == "back" else px, py, rotation)
    return x + dx, y + dy


def freeroute_boxes(dsn: str) -> dict[tuple[str, str], tuple[float, ...]]:
    """The pad obstacle freeroute 2026.7.14 reads (`board/build.py` `_pad_tile`, then its
    routers' `bounding_box()`): the first shape of the padstack, never turned, moved to the
    pin; a circle's box, a rect, the box of a polygon's or path's points (width ignored)."""
    out = {}
    for pin in _pins(dsn):
        kind, numbers = _shapes(pin[-1])[0]
        if kind == "circle":
            r = numbers[0] / 2
            cx, cy = numbers[1:3] if len(numbers) >= 3 else (0.0, 0.0)
            box = (cx - r, cy - r, cx + r, cy + r)
        else:
            points = numbers[:4] if kind == "rect" else numbers[1:]
            xs, ys = points[0::2], points[1::2]
            box = (min(xs), min(ys), max(xs), max(ys))
        x, y = _location(pin)
        out[pin[:2]] = (box[0] + x, box[1] + y, box[2] + x, box[3] + y)
    return out


def true_pads(dsn: str) -> dict[tuple[str, str], shapely.Geometry]:
    """Each pin's pad by the Specctra semantics: the shape turned by the pin's own rotation,
    mirrored for a back-side component, turned by the placement's rotation, moved to the pin."""
    out = {}
    for pin in _pins(dsn):
        kind, numbers = _shapes(pin[-1])[0]
        if kind == "rect":
            x1, y1, x2, y2 = numbers
            shape = shapely.box(x1, y1, x2, y2)
        elif kind == "path":
            points = list(zip(numbers[1::2], numbers[2::2]))
            line = shapely.LineString(points) if len(set(points)) > 1 else shapely.Point(points[0])
            shape = line.buffer(numbers[0] / 2, quad_segs=64)
        else:
            shape = shapely.Point(0, 0).buffer(numbers[0] / 2, quad_segs=64)
        shape = shapely.affinity.rotate(shape, pin[8], origin=(0, 0))
        if pin[4] == "back":
            shape = shapely.affinity.scale(shape, -1, 1, origin=(0, 0))
        shape = shapely.affinity.rotate(shape, pin[5], origin=(0, 0))
        out[pin[:2]] = shapely.affinity.translate(shape, *_location(pin))
    return out


def _uncovered(dsn: str, truth: dict) -> list[tuple[str, str]]:
    boxes = freeroute_boxes(dsn)
    return sorted(key for key, pad in truth.items()
                  if not shapely.box(*boxes[key]).buffer(0.01).contains(pad))


def _as_routed(dsn: str) -> str:
    return exact_pads(flip_back_components(dsn)[0])


def test_freeroute_reads_ovals_and_turned_pads_wrong_without_the_rewrite():
    truth = true_pads(DSN)
    assert _uncovered(flip_back_components(DSN)[0], truth) == [
        ("J1", "1"), ("J1", "2"), ("J2", "1"), ("J2", "2"), ("J3", "1"), ("J3", "2"),
        ("U1", "2"), ("U2", "1")]


def test_after_the_rewrite_every_pad_is_inside_what_freeroute_reads():
    truth = true_pads(DSN)
    routed = _as_routed(DSN)
    assert _uncovered(routed, truth) == []
    boxes = freeroute_boxes(routed)
    for key, pad in truth.items():  # and no more than 1 um bigger on any side
        x1, y1, x2, y2 = pad.bounds
        bx1, by1, bx2, by2 = boxes[key]
        assert max(x1 - bx1, y1 - by1, bx2 - x2, by2 - y2) < 1.0, key
    assert '(component "Lib:Chip__back__rot270"' in routed  # U2: mirrored, then turned
    assert "(path F.Cu" not in routed


def test_the_rewrite_keeps_placements_and_leaves_plain_boards_alone():
    routed = _as_routed(DSN)
    places = sorted(re.findall(r"\(place\s+(\S+\s+\S+\s+\S+)", routed))
    assert places == sorted(re.findall(r"\(place\s+(\S+\s+\S+\s+\S+)", DSN))
    plain = DSN.replace(" (rotate 90)", "").replace("90)", "0)").replace("270)", "0)")
    plain = re.sub(r"\(shape \(path \S+ [^)]*\)\)\s*", "", plain)  # no ovals either
    assert "__rot" not in exact_pads(plain)
    assert exact_pads("(pcb x (resolution um 10))") == "(pcb x (resolution um 10))"


@pytest.mark.parametrize("angle", [0.0, 45.0, 90.0, 180.0, 270.0, 30.5])
def test_a_turned_oval_is_held_at_any_angle(angle):
    dsn = DSN.replace("(place J2 30000 -20000 front 90)", f"(place J2 30000 -20000 front {angle})")
    truth = true_pads(dsn)
    assert [key for key in _uncovered(_as_routed(dsn), truth) if key[0] == "J2"] == []


# ---- a real board: KiCad's pads against what freeroute reads ------------------------------
#: A small D3-A board with oval through-hole pads on both sides and SMD rectangles.
REAL_BOARD = "kitspace_tt_opt101_module_b1"


@pytest.fixture(scope="module")
def real_board(tmp_path_factory, kicad_pool):
    from tests.evaluator.test_d3_reference import build_boards

    root, _ = build_boards(tmp_path_factory, kicad_pool, "oval-pads", [REAL_BOARD])
    (folder,) = (root / "d3-a" / "full").iterdir()
    return folder


def _dsn_and_pads(kicad_pool, folder, fixes: bool) -> dict:
    (outcome,) = kicad_pool.map("pcbdata.kicad.specctra:dsn_and_pads",
                                [(str(folder / "board.kicad_pcb"), str(folder), fixes)])
    assert outcome.ok, outcome.error
    return outcome.value


def _pads_outside(dsn: str, pads: list[dict]) -> tuple[list[str], int]:
    """(KiCad pads not inside the box freeroute reads for their pin, pads compared)."""
    boxes = {f"{ref}:{pin}": box for (ref, pin), box in freeroute_boxes(dsn).items()}
    outside, compared = [], 0
    for pad in pads:
        box = boxes.get(pad["name"])
        if box is None:
            continue
        compared += 1
        if not shapely.box(*box).buffer(0.01).contains(shapely.box(*pad["box"])):
            outside.append(pad["name"])
    return sorted(set(outside)), compared


def test_real_board_pads_are_inside_what_freeroute_reads(real_board, kicad_pool):
    kicad_dsn = _dsn_and_pads(kicad_pool, real_board, fixes=False)
    outside, compared = _pads_outside(kicad_dsn["dsn"], kicad_dsn["pads"])
    assert compared >= 25 and len(outside) >= 10  # KiCad's own DSN: ovals read as points
    routed = _dsn_and_pads(kicad_pool, real_board, fixes=True)
    outside, compared = _pads_outside(routed["dsn"], routed["pads"])
    assert compared >= 25 and outside == []

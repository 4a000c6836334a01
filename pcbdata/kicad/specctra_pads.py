"""Work-around for freeroute's pad model: pads as freeroute reads them are not the board's pads.

freeroute 2026.7.14 builds each pin's obstacle from the first shape of its padstack, moved to
the pin but never rotated, and reads a `(path LAYER WIDTH x1 y1 x2 y2)` shape as the box of
its two end points, without the width. KiCad writes every oval pad as such a path (a round
oval as a path of length 0), so to freeroute an oval through-hole pad is a line or a point and
it runs other nets' tracks through it; and a rectangular pad of a component turned by 90
degrees (or a pad turned in its footprint) keeps its unturned size.

`exact_pads` rewrites the DSN so that freeroute's reading is the board's geometry: ovals
become convex polygons that enclose them (a few micrometres larger at the corners), polygons
are written convex and counter-clockwise (freeroute's tile needs both, else it takes a box),
and every component whose pins turn (the placement's rotation plus the pin's own) gets an
image of its own with padstacks turned by that angle. Placements keep their position and
rotation, so pin positions and the routed copper are unchanged; the images only exist in the
DSN (the session's placement is not imported).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

from pcbdata.core.sexpr_text import block_end
from pcbdata.kicad.specctra_text import BACK_SUFFIX, suffixed

_TOKEN = r'(?:"(?:[^"\\]|\\.)*"|[^\s()]+)'
_SHAPE = re.compile(r"\(shape\s+\((rect|circle|polygon|path)\s+(" + _TOKEN + r")\s+([^()]*)\)\s*\)")
_PIN = re.compile(r"\(pin\s+(" + _TOKEN + r")((?:\s+\(rotate\s+-?[\d.]+\))?)\s+(" + _TOKEN
                  + r")\s+(-?[\d.]+)\s+(-?[\d.]+)\s*\)")
_ROTATE = re.compile(r"\(rotate\s+(-?[\d.]+)\)")
_PLACE = re.compile(r"\(place\s+" + _TOKEN + r"\s+-?[\d.]+\s+-?[\d.]+\s+(front|back)"
                    r"(?:\s+(-?[\d.]+))?")
#: Oval ends are circles drawn as polygons of 4 * QUAD_SEGS sides around them.
QUAD_SEGS = 4


@dataclass(frozen=True)
class PadShape:
    kind: str  # rect, circle, polygon, path
    layer: str
    numbers: tuple[float, ...]


def exact_pads(dsn: str) -> str:
    """The DSN with pads written as freeroute reads them right (see the module doc)."""
    stacks = _padstacks(dsn)
    if not stacks:
        return dsn
    turned: set[tuple[str, float]] = set()
    dsn = _turn_components(dsn, stacks, turned)
    return _rewrite_padstacks(dsn, stacks, turned)


# ---- reading -------------------------------------------------------------------------------

def _named_blocks(dsn: str, kind: str) -> list[tuple[str, int, int]]:
    """(name, start, end) of every `(kind NAME ...)` block."""
    out = []
    for match in re.finditer(r"\(" + kind + r"\s+(" + _TOKEN + r")", dsn):
        out.append((match.group(1), match.start(), block_end(dsn, match.start())))
    return out


def _padstacks(dsn: str) -> dict[str, list[PadShape]]:
    stacks = {}
    for name, start, end in _named_blocks(dsn, "padstack"):
        stacks[name] = [_pad_shape(m) for m in _SHAPE.finditer(dsn, start, end)]
    return stacks


def _pad_shape(match: re.Match) -> PadShape:
    return PadShape(match.group(1), match.group(2),
                    tuple(float(v) for v in match.group(3).split()))


def _angle(value: float) -> float:
    angle = round(value % 360.0, 6)
    return 0.0 if angle == 360.0 else angle


def _angle_suffix(angle: float) -> str:
    return "__rot" + f"{angle:f}".rstrip("0").rstrip(".").replace(".", "_")


# ---- components ----------------------------------------------------------------------------

def _turn_components(dsn: str, stacks: dict, turned: set) -> str:
    """Gives every (image, rotation) whose pins turn an image of its own on turned padstacks;
    adds the (padstack, angle) pairs those need to `turned`."""
    images = {name: (start, end) for name, start, end in _named_blocks(dsn, "image")}
    placement = re.search(r"\(placement\s", dsn)
    if placement is None:
        return dsn
    p_end = block_end(dsn, placement.start())
    out, pos, new_images = [], placement.start(), []
    for name, start, end in _named_blocks(dsn[:p_end], "component"):
        if start < placement.start() or name not in images:
            continue
        block, added = _split_component(dsn, name, start, end, images[name], stacks, turned)
        out += [dsn[pos:start], block]
        pos = end
        new_images += added
    out.append(dsn[pos:])
    dsn = dsn[:placement.start()] + "".join(out)
    return _add_to_library(dsn, new_images)


def _split_component(dsn: str, name: str, start: int, end: int, image_span: tuple[int, int],
                     stacks: dict, turned: set) -> tuple[str, list[str]]:
    """The component's placement block, split by rotation where pins turn; the new images."""
    image = dsn[image_span[0]:image_span[1]]
    back = name.strip('"').endswith(BACK_SUFFIX)
    groups: dict[float, list[str]] = {}
    for line in re.findall(r"\(place\s.*", dsn[start:end]):
        match = _PLACE.search(line)
        rotation = _angle(float(match.group(2) or 0)) if match else 0.0
        groups.setdefault(rotation, []).append(line.strip())
    by_image: dict[str, list[str]] = {}
    added = []
    for rotation, lines in sorted(groups.items()):
        turned_image = _turned_image(image, name, rotation, back, stacks, turned)
        if turned_image is None:
            by_image.setdefault(name, []).extend(lines)
            continue
        added.append(turned_image)
        by_image[suffixed(name, _angle_suffix(rotation))] = lines
    before = dsn[dsn.rfind("\n", 0, start) + 1:start]
    indent = before[:len(before) - len(before.lstrip())]
    blocks = ["(component " + image_name + "".join(f"\n{indent}  {line}" for line in lines)
              + f"\n{indent})" for image_name, lines in by_image.items()]
    return f"\n{indent}".join(blocks), added


def _turned_image(image: str, name: str, rotation: float, back: bool, stacks: dict,
                  turned: set) -> str | None:
    """The image with pins on padstacks turned by their angle, or None if no pin turns."""
    changed = False

    def pin(match: re.Match) -> str:
        nonlocal changed
        own = _ROTATE.search(match.group(2))
        own_angle = float(own.group(1)) if own else 0.0
        # A mirrored image's padstacks are mirrored already; a pad turned in the footprint
        # turns the other way in the mirror image, before the placement turns it.
        angle = _angle(rotation - own_angle if back else rotation + own_angle)
        stack = match.group(1)
        if angle == 0.0 or _turn_invariant(stacks.get(stack, []), angle):
            if not own:
                return match.group(0)
            changed = True
            return f"(pin {stack} {match.group(3)} {match.group(4)} {match.group(5)})"
        changed = True
        turned.add((stack, angle))
        return f"(pin {suffixed(stack, _angle_suffix(angle))} {match.group(3)} " \
               f"{match.group(4)} {match.group(5)})"

    body = _PIN.sub(pin, image)
    if not changed:
        return None
    return body.replace(name, suffixed(name, _angle_suffix(rotation)), 1)


def _turn_invariant(shapes: list[PadShape], angle: float) -> bool:
    """Whether turning by `angle` leaves the shapes as they are (centred circles always;
    centred rectangles and ovals by 180 degrees; polygons never, to be safe)."""
    for shape in shapes:
        if shape.kind == "circle":
            if len(shape.numbers) >= 3 and any(shape.numbers[1:3]):
                return False
            continue
        if angle != 180.0 or shape.kind == "polygon":
            return False
        points = shape.numbers if shape.kind == "rect" else shape.numbers[1:]
        xs, ys = points[0::2], points[1::2]
        if not (xs and math.isclose(min(xs), -max(xs), abs_tol=1e-6)
                and math.isclose(min(ys), -max(ys), abs_tol=1e-6)):
            return False
    return True


def _add_to_library(dsn: str, blocks: list[str]) -> str:
    if not blocks:
        return dsn
    library = re.search(r"\(library\s", dsn)
    if library is None:
        return dsn
    end = block_end(dsn, library.start()) - 1
    return dsn[:end] + "".join("\n    " + b for b in blocks) + "\n  " + dsn[end:]


# ---- padstacks -----------------------------------------------------------------------------

def _rewrite_padstacks(dsn: str, stacks: dict, turned: set) -> str:
    out, pos, added = [], 0, []
    for name, start, end in _named_blocks(dsn, "padstack"):
        block = dsn[start:end]
        out += [dsn[pos:start], _stack_at(block, 0.0)]
        pos = end
        added += [_stack_at(block, angle).replace(name, suffixed(name, _angle_suffix(angle)), 1)
                  for stack, angle in sorted(turned) if stack == name]
    out.append(dsn[pos:])
    return _add_to_library("".join(out), added)


def _stack_at(block: str, angle: float) -> str:
    def shape(match: re.Match) -> str:
        return f"(shape {shape_text(_pad_shape(match), angle)})"

    return _SHAPE.sub(shape, block)


def shape_text(pad: PadShape, angle: float) -> str:
    """The DSN shape freeroute reads as `pad` turned by `angle` degrees (counter-clockwise in
    DSN coordinates, the direction of a placement's rotation)."""
    if pad.kind == "circle":
        centre = pad.numbers[1:3] if len(pad.numbers) >= 3 else (0.0, 0.0)
        if not any(centre):
            return f"(circle {pad.layer} {_fmt(pad.numbers[0])})"
        x, y = _turn(centre[0], centre[1], angle)
        return f"(circle {pad.layer} {_fmt(pad.numbers[0])} {_fmt(x)} {_fmt(y)})"
    if pad.kind == "rect" and angle % 90.0 == 0.0:
        x1, y1, x2, y2 = pad.numbers[:4]
        corners = [_turn(x, y, angle) for x, y in ((x1, y1), (x2, y2))]
        xs, ys = [c[0] for c in corners], [c[1] for c in corners]
        return f"(rect {pad.layer} {_fmt(min(xs))} {_fmt(min(ys))} {_fmt(max(xs))} " \
               f"{_fmt(max(ys))})"
    ring = [_turn(x, y, angle) for x, y in _outline(pad)]
    return f"(polygon {pad.layer} 0 {' '.join(f'{_fmt(x)} {_fmt(y)}' for x, y in ring)})"


def _outline(pad: PadShape) -> list[tuple[float, float]]:
    """The corners of a convex, counter-clockwise polygon that holds the pad (not closed)."""
    import shapely
    from shapely.geometry import Polygon

    if pad.kind == "rect":
        x1, y1, x2, y2 = pad.numbers[:4]
        area = Polygon([(x1, y1), (x2, y1), (x2, y2), (x1, y2)])
    elif pad.kind == "polygon":
        points = list(zip(pad.numbers[1::2], pad.numbers[2::2]))
        area = Polygon(points).buffer(pad.numbers[0] / 2) if pad.numbers[0] else \
            shapely.MultiPoint(points)
    else:  # a path: the stadium of its width around its points
        area = shapely.MultiPoint(_circle_corners(pad.numbers[0] / 2, pad.numbers[1:]))
    hull = shapely.geometry.polygon.orient(area.convex_hull.simplify(0), sign=1.0)
    return list(hull.exterior.coords)[:-1]


def _circle_corners(radius: float, numbers) -> list[tuple[float, float]]:
    """Corners of polygons around circles of `radius` at the points `numbers` (x, y, ...):
    a corner on every 1 / (4 QUAD_SEGS) turn, half a step off the axes, at the radius whose
    sides touch the circle, so the polygon holds the circle and its box is the circle's."""
    sides = 4 * QUAD_SEGS
    step = 2 * math.pi / sides
    outer = radius / math.cos(step / 2) + 0.01  # 0.01: rounding to 3 decimals stays outside
    return [(x + outer * math.cos((k + 0.5) * step), y + outer * math.sin((k + 0.5) * step))
            for x, y in zip(numbers[0::2], numbers[1::2]) for k in range(sides)]


def _turn(x: float, y: float, angle: float) -> tuple[float, float]:
    if angle == 0.0:
        return x, y
    a = math.radians(angle)
    c, s = round(math.cos(a), 12), round(math.sin(a), 12)
    return x * c - y * s, x * s + y * c


def _fmt(value: float) -> str:
    text = f"{round(value, 3):f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text

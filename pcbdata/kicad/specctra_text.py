"""Work-around for routers that ignore the `back` side of Specctra placements.

freeroute 2026.7.14 treats a component placed `back` as if its pads were on the front layer,
so it routes over back-side SMD pads on B.Cu (shorts) and ends tracks on F.Cu where the pad
is on B.Cu (open connections). `flip_back_components` rewrites the DSN so every back-placed
component uses a mirrored image (x negated, F.Cu <-> B.Cu swapped in its padstacks) placed
`front`; `restore_back_placements` puts `back` back into the router's SES so KiCad does not
move anything on import. Exact for one-pad footprints at the origin (D1, D2); for other
footprints the mirrored geometry follows the usual mirror-about-Y convention.
"""
from __future__ import annotations

import re

from pcbdata.core.sexpr_text import block_end

_PLACE = re.compile(r"^(\s*\(place\s+(\S+)\s+\S+\s+\S+\s+)back(\s)", re.M)
_COMPONENT = re.compile(r"^(\s*)\(component\s+(\S+)\s*$", re.M)
BACK_SUFFIX = "__back"


def suffixed(name: str, suffix: str) -> str:
    """A DSN name with `suffix` added, inside the quotes of a quoted name (KiCad quotes names
    such as "Lib:Part-1"; a suffix after the closing quote would be a token of its own, and
    the router would read the unsuffixed name)."""
    return name[:-1] + suffix + '"' if len(name) > 1 and name.startswith('"') else name + suffix


def _block(text: str, start: int) -> int:
    """Index just past the s-expression that opens at `text[start] == '('`."""
    try:
        return block_end(text, start)
    except ValueError:
        raise ValueError("unbalanced DSN") from None


def _find_named(text: str, kind: str, name: str) -> tuple[int, int] | None:
    match = re.search(r"\(" + kind + r"\s+" + re.escape(name) + r"(?=[\s)])", text)
    if match is None:
        return None
    return match.start(), _block(text, match.start())


def _negate_x(numbers: str) -> str:
    values = numbers.split()
    def negate(v: str) -> str:
        return v if v in ("0", "-0") else (v[1:] if v.startswith("-") else "-" + v)

    return " ".join(v if i % 2 else negate(v) for i, v in enumerate(values))


def _mirror_padstack(body: str, name: str) -> str:
    body = body.replace(name, suffixed(name, BACK_SUFFIX), 1)
    body = body.replace("F.Cu", "\0").replace("B.Cu", "F.Cu").replace("\0", "B.Cu")

    def shape(match: re.Match) -> str:
        kind, layer, rest = match.group(1), match.group(2), match.group(3)
        if kind == "polygon":
            width, _, coords = rest.strip().partition(" ")
            return f"({kind} {layer} {width} {_negate_x(coords)})"
        if kind == "rect":
            return f"({kind} {layer} {_negate_x(rest)})"
        if kind == "circle":
            parts = rest.split()
            if len(parts) == 3:
                parts[1] = _negate_x(parts[1])
            return f"({kind} {layer} {' '.join(parts)})"
        return match.group(0)

    return re.sub(r"\((polygon|rect|circle)\s+(\S+)\s+([^()]*)\)", shape, body, flags=re.S)


def flip_back_components(dsn: str) -> tuple[str, set[str]]:
    """(rewritten DSN, references of the components that were placed `back`)."""
    refs = {m.group(2) for m in _PLACE.finditer(dsn)}
    if not refs:
        return dsn, set()
    images: set[str] = set()
    out, pos = [], 0
    for comp in _COMPONENT.finditer(dsn):
        start = comp.start(0) + len(comp.group(1))
        end = _block(dsn, start)
        block = dsn[start:end]
        backs = [line for line in block.splitlines() if _PLACE.match(line)]
        if not backs:
            continue
        image = comp.group(2)
        images.add(image)
        kept = "\n".join(line for line in block.splitlines() if not _PLACE.match(line))
        flipped = "\n".join(_PLACE.sub(r"\1front\3", line) for line in backs)
        indent = comp.group(1).lstrip("\n")
        new = f"{kept}\n{indent}(component {suffixed(image, BACK_SUFFIX)}\n{flipped}\n{indent})"
        out.append(dsn[pos:start])
        out.append(new)
        pos = end
    out.append(dsn[pos:])
    dsn = "".join(out)
    stacks: set[str] = set()
    extra_images = []
    for image in sorted(images):
        span = _find_named(dsn, "image", image)
        if span is None:
            continue
        body = dsn[span[0]:span[1]].replace(image, suffixed(image, BACK_SUFFIX), 1)

        def pin(match: re.Match) -> str:
            stacks.add(match.group(2))
            x = match.group(4)
            x = x[1:] if x.startswith("-") else ("-" + x if x not in ("0", "0.0") else x)
            return f"{match.group(1)}{suffixed(match.group(2), BACK_SUFFIX)}{match.group(3)}{x}" \
                   f"{match.group(5)}"

        body = re.sub(r"(\(pin\s+)(\S+)((?:\s+\(rotate\s+[^)]*\))?\s+\S+\s+)"
                      r"(-?[\d.]+)(\s+-?[\d.]+)", pin, body)
        extra_images.append(body)
    extra_stacks = []
    for stack in sorted(stacks):
        span = _find_named(dsn, "padstack", stack)
        if span is not None:
            extra_stacks.append(_mirror_padstack(dsn[span[0]:span[1]], stack))
    lib = re.search(r"\(library\s", dsn)
    if lib is None:
        return dsn, refs
    lib_end = _block(dsn, lib.start()) - 1
    addition = "".join("\n    " + block for block in extra_images + extra_stacks) + "\n  "
    return dsn[:lib_end] + addition + dsn[lib_end:], refs


def restore_back_placements(ses: str, refs: set[str]) -> str:
    """Puts `back` back into the SES placements of `refs` and the original image names."""
    def place(match: re.Match) -> str:
        if match.group(2) in refs:
            return match.group(1) + "back" + match.group(4)
        return match.group(0)

    ses = re.sub(r"(\(place\s+(\S+)\s+\S+\s+\S+\s+)(front)(\s)", place, ses)
    return ses.replace(BACK_SUFFIX, "")


# --- freeroute's via model -------------------------------------------------------------------
# freeroute 2026.7.14 models every via as a square the size of a track and never reads the via
# padstack's size, so it drops 1.2 mm vias 0.6 mm from other nets' tracks. Planning with tracks
# as wide as the largest via makes every track keep room for a via; the real widths are written
# back into the session before KiCad imports it.

_WIDTH = re.compile(r"\(width\s+([\d.]+)\)")
_CIRCLE = re.compile(r"\(circle\s+\S+\s+([\d.]+)")
_NAME = r'("(?:[^"\\]|\\.)*"|[^\s()]+)'


def via_diameters(dsn: str) -> list[float]:
    """Diameters of the padstacks the DSN declares as vias (`(via ...)`, `(use_via ...)`)."""
    names = set()
    for match in re.finditer(r"\((?:via|use_via)\s+" + _NAME, dsn):
        names.add(match.group(1).strip('"'))
    sizes = []
    for name in sorted(names):
        span = _find_padstack(dsn, name)
        if span is not None:
            sizes += [float(d) for d in _CIRCLE.findall(dsn[span[0]:span[1]])]
    return sizes


def _find_padstack(dsn: str, name: str) -> tuple[int, int] | None:
    quoted = re.escape(f'"{name}"') + "|" + re.escape(name)
    match = re.search(r"\(padstack\s+(?:" + quoted + r")(?=[\s)])", dsn)
    return None if match is None else (match.start(), _block(dsn, match.start()))


def _rule_blocks(dsn: str) -> list[tuple[int, int]]:
    return [(m.start(), _block(dsn, m.start())) for m in re.finditer(r"\(rule\s", dsn)]


def net_widths(dsn: str) -> tuple[float | None, dict[str, float]]:
    """(default track width of the structure rule, {net: width of its class rule})."""
    default = None
    structure = re.search(r"\(structure\s", dsn)
    if structure is not None:
        end = _block(dsn, structure.start())
        rule = re.search(r"\(rule\s", dsn[structure.start():end])
        if rule is not None:
            width = _WIDTH.search(dsn, structure.start() + rule.start())
            default = float(width.group(1)) if width else None
    per_net: dict[str, float] = {}
    for match in re.finditer(r"\(class\s+" + _NAME, dsn):
        block = dsn[match.start():_block(dsn, match.start())]
        head = block.split("(", 2)[1][len("class"):]  # names before the first sub-block
        width = _WIDTH.search(block)
        if width is None:
            continue
        for net in re.findall(_NAME, head)[1:]:
            per_net[net.strip('"')] = float(width.group(1))
    return default, per_net


def widen_wires_for_vias(dsn: str) -> tuple[str, float | None]:
    """The DSN with every rule's track width raised to the largest via diameter, and that
    planning width (None when the DSN declares no via, or no width is smaller)."""
    vias = via_diameters(dsn)
    if not vias:
        return dsn, None
    planning = max(vias)
    out, pos = [], 0
    for start, end in _rule_blocks(dsn):
        block = _WIDTH.sub(lambda m: f"(width {_number(max(float(m.group(1)), planning))})",
                           dsn[start:end])
        out += [dsn[pos:start], block]
        pos = end
    out.append(dsn[pos:])
    return "".join(out), planning


def restore_wire_widths(ses: str, planning: float, default: float | None,
                        per_net: dict[str, float]) -> str:
    """Writes each net's real track width back over the planning width in the SES wires."""
    out, pos = [], 0
    for match in re.finditer(r"\(net\s+" + _NAME, ses):
        if match.start() < pos:
            continue
        end = _block(ses, match.start())
        real = per_net.get(match.group(1).strip('"'), default)
        block = ses[match.start():end]
        if real is not None:
            block = _rewrite_widths(block, planning, real)
        out += [ses[pos:match.start()], block]
        pos = end
    out.append(ses[pos:])
    return "".join(out)


def _rewrite_widths(block: str, planning: float, real: float) -> str:
    def width(match: re.Match) -> str:
        old = match.group(2)
        return match.group(1) + (_number(real) if float(old) == planning else old)

    return re.sub(r"(\((?:path|polyline_path|qarc)\s+\S+\s+)([\d.]+)", width, block)


def _number(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else f"{value:g}"


# --- the routing boundary ---------------------------------------------------------------------
# freeroute keeps only half a track from the boundary, so on small boards it runs tracks (and
# drops vias) on the board edge. Shrinking the boundary by via radius + clearance keeps every
# track and via its clearance from Edge.Cuts.

_BOUNDARY_PATH = re.compile(r"(\(boundary\s*\(path\s+pcb\s+[\d.]+)((?:\s+-?[\d.]+)+)(\s*\))")


def structure_clearance(dsn: str) -> float:
    structure = re.search(r"\(structure\s", dsn)
    if structure is None:
        return 0.0
    block = dsn[structure.start():_block(dsn, structure.start())]
    match = re.search(r"\(clearance\s+([\d.]+)\)", block)
    return float(match.group(1)) if match else 0.0


def shrink_boundary(dsn: str, margin: float) -> str:
    """The DSN with its outer routing boundary inset by `margin` (DSN units); unchanged when
    the boundary is not a polygon path or would vanish."""
    from shapely.geometry import Polygon

    match = _BOUNDARY_PATH.search(dsn)
    if match is None or margin <= 0:
        return dsn
    values = [float(v) for v in match.group(2).split()]
    ring = list(zip(values[0::2], values[1::2]))
    inset = Polygon(ring).buffer(-margin, join_style="mitre")
    if inset.is_empty or inset.geom_type != "Polygon":
        return dsn
    coords = list(inset.exterior.coords)
    text = "  ".join(f"{_number(round(x, 1))} {_number(round(y, 1))}" for x, y in coords)
    return dsn[:match.start()] + match.group(1) + "  " + text + match.group(3) + dsn[match.end():]


def prepare_dsn_for_freeroute(dsn: str) -> tuple[str, dict]:
    """Applies both freeroute work-arounds to a DSN; returns it with what the SES needs back."""
    default, per_net = net_widths(dsn)
    vias = via_diameters(dsn)
    margin = (max(vias) / 2 if vias else (default or 0) / 2) + structure_clearance(dsn)
    widened, planning = widen_wires_for_vias(shrink_boundary(dsn, margin))
    return widened, {"planning": planning, "default": default, "per_net": per_net}


def restore_ses_after_freeroute(ses: str, state: dict) -> str:
    if state.get("planning") is None:
        return ses
    return restore_wire_widths(ses, state["planning"], state["default"], state["per_net"])

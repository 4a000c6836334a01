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

from pcbdata.sexpr_text import block_end

_PLACE = re.compile(r"^(\s*\(place\s+(\S+)\s+\S+\s+\S+\s+)back(\s)", re.M)
_COMPONENT = re.compile(r"^(\s*)\(component\s+(\S+)\s*$", re.M)
_SUFFIX = "__back"


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
    body = body.replace(name, name + _SUFFIX, 1)
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
        new = f"{kept}\n{indent}(component {image}{_SUFFIX}\n{flipped}\n{indent})"
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
        body = dsn[span[0]:span[1]].replace(image, image + _SUFFIX, 1)

        def pin(match: re.Match) -> str:
            stacks.add(match.group(2))
            x = match.group(4)
            x = x[1:] if x.startswith("-") else ("-" + x if x not in ("0", "0.0") else x)
            return f"{match.group(1)}{match.group(2)}{_SUFFIX}{match.group(3)}{x}{match.group(5)}"

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
    return ses.replace(_SUFFIX, "")

"""Writes a `Board` as KiCad 9 files: `.kicad_pcb`, `.kicad_pro` and, where needed, `.kicad_dru`.

The output is a pure function of the board: numbers are formatted from integer nanometres and
UUIDs are derived from the board's `uuid_seed`, so the same board gives the same bytes.
"""
from __future__ import annotations

import hashlib
import uuid

from pcbdata.core.textio import canonical_json
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, RULES_FILE
from pcbdata.model.board import Board, EdgeArc, NetClass, Pad, Part, PartPad, Rules

KICAD_PCB_VERSION = 20241229  # the file format KiCad 9.0 writes
GENERATOR = "pcbdata"

# The layer table KiCad 9 writes for a two-layer board (ids changed in 9.0: B.Cu is 2).
_LAYERS = """\t(layers
\t\t(0 "F.Cu" signal)
\t\t(2 "B.Cu" signal)
\t\t(9 "F.Adhes" user "F.Adhesive")
\t\t(11 "B.Adhes" user "B.Adhesive")
\t\t(13 "F.Paste" user)
\t\t(15 "B.Paste" user)
\t\t(5 "F.SilkS" user "F.Silkscreen")
\t\t(7 "B.SilkS" user "B.Silkscreen")
\t\t(1 "F.Mask" user)
\t\t(3 "B.Mask" user)
\t\t(17 "Dwgs.User" user "User.Drawings")
\t\t(19 "Cmts.User" user "User.Comments")
\t\t(21 "Eco1.User" user "User.Eco1")
\t\t(23 "Eco2.User" user "User.Eco2")
\t\t(25 "Edge.Cuts" user)
\t\t(27 "Margin" user)
\t\t(31 "F.CrtYd" user "F.Courtyard")
\t\t(29 "B.CrtYd" user "B.Courtyard")
\t\t(35 "F.Fab" user)
\t\t(33 "B.Fab" user)
\t)
"""


# Inner copper layers of a four-layer board (KiCad 9 numbers them 4, 6, ...).
_INNER = '\t\t(2 "B.Cu" signal)\n'
_INNER_4 = '\t\t(4 "In1.Cu" signal)\n\t\t(6 "In2.Cu" signal)\n' + _INNER


def _layer_table(copper_layers: int) -> str:
    if copper_layers == 2:
        return _LAYERS
    if copper_layers == 4:
        return _LAYERS.replace(_INNER, _INNER_4, 1)
    raise ValueError(f"boards have 2 or 4 copper layers, not {copper_layers}")


def mm(value_nm: int) -> str:
    """Formats nanometres as KiCad writes millimetres: shortest exact decimal."""
    sign = "-" if value_nm < 0 else ""
    whole, frac = divmod(abs(int(value_nm)), 1_000_000)
    if frac == 0:
        return f"{sign}{whole}"
    return f"{sign}{whole}.{frac:06d}".rstrip("0")


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


class _Uuids:
    """Deterministic UUIDs: the n-th UUID of a board depends only on its seed and n."""

    def __init__(self, seed: str):
        self._seed = seed.encode()
        self._count = 0

    def next(self) -> str:
        self._count += 1
        digest = hashlib.sha256(self._seed + b"/" + str(self._count).encode()).digest()
        return str(uuid.UUID(bytes=digest[:16], version=4))


def net_numbers(board: Board) -> dict[str, int]:
    return {name: i for i, name in enumerate(board.net_names, start=1)}


def _pad_sexpr(pad: Pad, net_no: int, uid: str) -> list[str]:
    at, size = "(at 0 0)", f"(size {mm(pad.size)} {mm(pad.size)})"
    net = f"(net {net_no} {_quote(pad.net)})"
    side = pad.layer[0]
    if pad.kind == "thru_round":
        head = '(pad "1" thru_hole circle'
        body = [at, size, f"(drill {mm(pad.drill)})", '(layers "*.Cu" "*.Mask")',
                "(remove_unused_layers no)"]
    elif pad.kind == "smd_roundrect":
        head = '(pad "1" smd roundrect'
        body = [at, size, f'(layers "{side}.Cu" "{side}.Mask" "{side}.Paste")',
                f"(roundrect_rratio {pad.roundrect_ratio:g})"]
    else:
        head = '(pad "1" smd rect'
        body = [at, size, f'(layers "{side}.Cu" "{side}.Mask" "{side}.Paste")']
    lines = [f"\t\t\t{b}" for b in body + [net, f"(uuid {_quote(uid)})"]]
    return [f"\t\t{head}", *lines, "\t\t)"]


def _footprint(pad: Pad, ref: str, net_no: int, uuids: _Uuids) -> str:
    side = pad.layer[0] if pad.kind != "thru_round" else "F"
    fab = f"{side}.Fab"
    lines = [
        '\t(footprint "Pad"',
        f'\t\t(layer "{side}.Cu")',
        f"\t\t(uuid {_quote(uuids.next())})",
        f"\t\t(at {mm(pad.x)} {mm(pad.y)})",
    ]
    for prop, value in (("Reference", ref), ("Value", pad.net)):
        lines += [
            f"\t\t(property {_quote(prop)} {_quote(value)}",
            "\t\t\t(at 0 0 0)",
            f'\t\t\t(layer "{fab}")',
            "\t\t\t(hide yes)",
            f"\t\t\t(uuid {_quote(uuids.next())})",
            "\t\t\t(effects (font (size 1 1) (thickness 0.15)))",
            "\t\t)",
        ]
    lines.append("\t\t(attr through_hole)" if pad.kind == "thru_round" else "\t\t(attr smd)")
    lines += _pad_sexpr(pad, net_no, uuids.next())
    lines += ["\t\t(embedded_fonts no)", "\t)"]
    return "\n".join(lines) + "\n"


def _part_pad_sexpr(part: Part, pad: PartPad, net_no: int, uid: str) -> list[str]:
    side = part.side
    dx = -pad.dx if side == "B" else pad.dx  # the file holds a flipped part's own frame flipped
    angle = f" {part.rotation}" if part.rotation else ""
    at, size = f"(at {mm(dx)} {mm(pad.dy)}{angle})", f"(size {mm(pad.width)} {mm(pad.height)})"
    if pad.drill and not pad.plated:
        head = f'(pad "" np_thru_hole {pad.shape}'
        body = [at, size, f"(drill {mm(pad.drill)})", '(layers "*.Cu" "*.Mask")']
    elif pad.drill:
        head = f'(pad {_quote(pad.number)} thru_hole {pad.shape}'
        body = [at, size, f"(drill {mm(pad.drill)})", '(layers "*.Cu" "*.Mask")',
                "(remove_unused_layers no)"]
    else:
        head = f'(pad {_quote(pad.number)} smd {pad.shape}'
        body = [at, size, f'(layers "{side}.Cu" "{side}.Mask" "{side}.Paste")']
    if pad.shape == "roundrect":
        body.append(f"(roundrect_rratio {pad.roundrect_ratio:g})")
    if pad.net:
        body.append(f"(net {net_no} {_quote(pad.net)})")
    lines = [f"\t\t\t{b}" for b in body + [f"(uuid {_quote(uid)})"]]
    return [f"\t\t{head}", *lines, "\t\t)"]


def _part_attr(part: Part) -> str:
    if not any(pad.plated for pad in part.pads):
        return "\t\t(attr exclude_from_pos_files exclude_from_bom)"
    return "\t\t(attr through_hole)" if part.through_hole else "\t\t(attr smd)"


def _part(part: Part, numbers: dict[str, int], uuids: _Uuids) -> str:
    side = part.side
    angle = f" {part.rotation}" if part.rotation else ""
    lines = [
        f"\t(footprint {_quote(part.name)}",
        f'\t\t(layer "{side}.Cu")',
        f"\t\t(uuid {_quote(uuids.next())})",
        f"\t\t(at {mm(part.x)} {mm(part.y)}{angle})",
    ]
    for prop, value in (("Reference", part.ref), ("Value", part.name)):
        lines += [
            f"\t\t(property {_quote(prop)} {_quote(value)}",
            f"\t\t\t(at 0 0{angle})",
            f'\t\t\t(layer "{side}.Fab")',
            "\t\t\t(hide yes)",
            f"\t\t\t(uuid {_quote(uuids.next())})",
            "\t\t\t(effects (font (size 1 1) (thickness 0.15))"
            + (" (justify mirror)" if side == "B" else "") + ")",
            "\t\t)",
        ]
    lines.append(_part_attr(part))
    half_w, half_h = part.courtyard
    lines += [
        "\t\t(fp_rect",
        f"\t\t\t(start {mm(-half_w)} {mm(-half_h)})",
        f"\t\t\t(end {mm(half_w)} {mm(half_h)})",
        "\t\t\t(stroke\n\t\t\t\t(width 0.05)\n\t\t\t\t(type solid)\n\t\t\t)",
        "\t\t\t(fill no)",
        f'\t\t\t(layer "{side}.CrtYd")',
        f"\t\t\t(uuid {_quote(uuids.next())})",
        "\t\t)",
    ]
    for pad in part.pads:
        lines += _part_pad_sexpr(part, pad, numbers.get(pad.net, 0), uuids.next())
    lines += ["\t\t(embedded_fonts no)", "\t)"]
    return "\n".join(lines) + "\n"


def _outline(board: Board, uuids: _Uuids) -> str:
    stroke = "\t\t(stroke\n\t\t\t(width 0.05)\n\t\t\t(type default)\n\t\t)\n"
    if not board.outline:
        return ("\t(gr_rect\n"
                f"\t\t(start 0 0)\n\t\t(end {mm(board.width)} {mm(board.height)})\n"
                f"{stroke}"
                '\t\t(fill no)\n\t\t(layer "Edge.Cuts")\n'
                f"\t\t(uuid {_quote(uuids.next())})\n\t)\n")
    out = []
    for edge in board.outline:
        if isinstance(edge, EdgeArc):
            head = (f"\t(gr_arc\n\t\t(start {mm(edge.x1)} {mm(edge.y1)})\n"
                    f"\t\t(mid {mm(edge.xm)} {mm(edge.ym)})\n")
        else:
            head = f"\t(gr_line\n\t\t(start {mm(edge.x1)} {mm(edge.y1)})\n"
        out.append(f"{head}\t\t(end {mm(edge.x2)} {mm(edge.y2)})\n{stroke}"
                   f'\t\t(layer "Edge.Cuts")\n\t\t(uuid {_quote(uuids.next())})\n\t)\n')
    return "".join(out)


def board_text(board: Board) -> str:
    """The `.kicad_pcb` text of a board."""
    uuids = _Uuids(board.uuid_seed)
    numbers = net_numbers(board)
    out = [
        "(kicad_pcb\n",
        f"\t(version {KICAD_PCB_VERSION})\n",
        f'\t(generator "{GENERATOR}")\n',
        '\t(generator_version "9.0")\n',
        "\t(general\n\t\t(thickness 1.6)\n\t\t(legacy_teardrops no)\n\t)\n",
        '\t(paper "A4")\n',
        _layer_table(board.copper_layers),
        "\t(setup\n\t\t(pad_to_mask_clearance 0)\n"
        "\t\t(allow_soldermask_bridges_in_footprints no)\n\t\t(tenting front back)\n\t)\n",
        '\t(net 0 "")\n',
    ]
    out += [f"\t(net {no} {_quote(name)})\n" for name, no in numbers.items()]
    for i, pad in enumerate(board.pads, start=1):
        out.append(_footprint(pad, f"P{i}", numbers[pad.net], uuids))
    out += [_part(part, numbers, uuids) for part in board.parts]
    out.append(_outline(board, uuids))
    for t in board.tracks:
        out.append(
            f"\t(segment\n\t\t(start {mm(t.x1)} {mm(t.y1)})\n\t\t(end {mm(t.x2)} {mm(t.y2)})\n"
            f"\t\t(width {mm(t.width)})\n\t\t(layer {_quote(t.layer)})\n"
            f"\t\t(net {numbers[t.net]})\n"
            f"\t\t(uuid {_quote(uuids.next())})\n\t)\n"
        )
    for a in board.arcs:
        out.append(
            f"\t(arc\n\t\t(start {mm(a.x1)} {mm(a.y1)})\n\t\t(mid {mm(a.xm)} {mm(a.ym)})\n"
            f"\t\t(end {mm(a.x2)} {mm(a.y2)})\n\t\t(width {mm(a.width)})\n"
            f"\t\t(layer {_quote(a.layer)})\n\t\t(net {numbers[a.net]})\n"
            f"\t\t(uuid {_quote(uuids.next())})\n\t)\n"
        )
    for v in board.vias:
        out.append(
            f"\t(via\n\t\t(at {mm(v.x)} {mm(v.y)})\n\t\t(size {mm(v.diameter)})\n"
            f'\t\t(drill {mm(v.drill)})\n\t\t(layers "F.Cu" "B.Cu")\n\t\t(net {numbers[v.net]})\n'
            f"\t\t(uuid {_quote(uuids.next())})\n\t)\n"
        )
    out.append("\t(embedded_fonts no)\n)\n")
    return "".join(out)


# The floors every board had before vias were held to the netclass; D1 keeps them.
_LEGACY_VIA_FLOOR_NM = 500_000
_LEGACY_HOLE_FLOOR_NM = 300_000


def via_floors(rules: Rules) -> tuple[int, int]:
    """The project's smallest via diameter and hole (nm).

    Where vias are allowed these are the netclass via and drill, so KiCad's DRC flags a smaller
    via (`via_diameter`, `drill_out_of_range`): a router must not pass a gap by shrinking its
    vias. KiCad applies the hole floor to pad holes too, so the generators keep pad drills at or
    above the via drill. A one-layer board (D1) forbids every via by its custom rule, so the
    floors decide nothing there; it keeps the older ones and with them its released bytes.
    """
    if rules.single_layer is not None:
        return (min(_LEGACY_VIA_FLOOR_NM, rules.via_diameter),
                min(_LEGACY_HOLE_FLOOR_NM, rules.via_drill))
    return rules.via_diameter, rules.via_drill


def _as_mm(nm: int) -> float:
    return float(mm(nm))


def _class_entry(net_class: NetClass, priority: int) -> dict:
    return {"name": net_class.name, "clearance": _as_mm(net_class.clearance),
            "track_width": _as_mm(net_class.track_width),
            "via_diameter": _as_mm(net_class.via_diameter),
            "via_drill": _as_mm(net_class.via_drill), "priority": priority}


def _add_net_classes(project: dict, net_classes: tuple[NetClass, ...]) -> None:
    """Classes after Default, each net assigned by an exact-name pattern."""
    settings = project["net_settings"]
    settings["classes"] += [_class_entry(c, k) for k, c in enumerate(net_classes)]
    settings["netclass_patterns"] = [{"netclass": c.name, "pattern": net}
                                     for c in net_classes for net in c.nets]


def project_text(rules: Rules, filename: str = PROJECT_FILE,
                 net_classes: tuple[NetClass, ...] = ()) -> str:
    """The `.kicad_pro` JSON: design rules and the Default netclass (and `net_classes` with
    their nets); KiCad fills the rest."""
    as_mm = _as_mm
    via_floor, hole_floor = via_floors(rules)
    project = {
        "board": {
            "design_settings": {
                "rules": {
                    "min_clearance": 0.0,
                    "min_copper_edge_clearance": as_mm(rules.edge_clearance),
                    "min_track_width": as_mm(rules.track_width),
                    "min_via_diameter": as_mm(via_floor),
                    "min_through_hole_diameter": as_mm(hole_floor),
                },
            },
        },
        "meta": {"filename": filename, "version": 3},
        "net_settings": {
            "classes": [
                {
                    "name": "Default",
                    "clearance": as_mm(rules.clearance),
                    "track_width": as_mm(rules.track_width),
                    "via_diameter": as_mm(rules.via_diameter),
                    "via_drill": as_mm(rules.via_drill),
                    "priority": 2147483647,
                }
            ],
            "meta": {"version": 4},
        },
    }
    if net_classes:
        _add_net_classes(project, net_classes)
    return canonical_json(project, indent=2)


def _class_rule(net_class: NetClass) -> str:
    """A net class's own minima as a DRC rule: the project's board minima are the finest
    class's, so without it a track of a wider class could shrink to them unflagged."""
    return (f'(rule "netclass {net_class.name}"\n'
            f"\t(condition \"A.NetClass == '{net_class.name}'\")\n"
            f"\t(constraint clearance (min {mm(net_class.clearance)}mm))\n"
            f"\t(constraint track_width (min {mm(net_class.track_width)}mm))\n"
            f"\t(constraint via_diameter (min {mm(net_class.via_diameter)}mm))\n"
            f"\t(constraint hole_size (min {mm(net_class.via_drill)}mm)))\n")


def custom_rules_text(rules: Rules, net_classes: tuple[NetClass, ...] = ()) -> str | None:
    """The `.kicad_dru` custom rules, or None when the board needs none.

    The one-layer routing of D1 is a DRC rule, not a convention, so that any router's output
    that uses the other copper layer (tracks or vias) is flagged by KiCad itself. Net classes
    (realistic boards) get one rule each.
    """
    if net_classes:
        return "(version 1)\n" + "".join(_class_rule(c) for c in net_classes)
    if rules.single_layer is None:
        return None
    other = "B.Cu" if rules.single_layer == "F.Cu" else "F.Cu"
    return (
        "(version 1)\n"
        '(rule "single_layer_routing"\n'
        f'\t(layer "{other}")\n'
        "\t(constraint disallow track via))\n"
    )


def board_files(board: Board) -> dict[str, str]:
    """File name -> text for every file of one board directory."""
    files = {BOARD_FILE: board_text(board),
             PROJECT_FILE: project_text(board.rules, net_classes=board.net_classes)}
    dru = custom_rules_text(board.rules, board.net_classes)
    if dru is not None:
        files[RULES_FILE] = dru
    return files

"""The KiCad side of the evaluator: measures a submitted board on its instance's own board.

Runs inside engine worker processes only (`pcbdata.kicad.pool.KicadPool`). Every function
returns plain data; the metrics themselves (DRC buckets, routability, potential, integrity) are
computed from these measurements by the pure modules of `pcbdata.evaluator`.

A submission may only add or change copper (tracks, arcs, vias), and a board file can carry
rules (legacy net classes, legacy setup keys, local clearance overrides on pads, footprints and
zones...) that KiCad obeys. So the board KiCad checks is never the submitted one: it is the
instance's own board, loaded with the instance's project, with the submission's tracks, arcs
and vias copied onto it (geometry, layers, width, via size/drill/type; nets matched by name).
Everything else the submission carries is only compared with the instance (`fingerprint`),
so that a difference makes the rollout invalid instead of changing its score.
"""
from __future__ import annotations

import math
import os
import re
import tempfile

from pcbdata.core.copper_geometry import arc_length, items_outside, outline_shape
from pcbdata.core.copper_text import copper_in_file, file_problems, kind_counts
from pcbdata.core.sexpr_text import block_end
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, RULES_FILE
from pcbdata.kicad.basics import board_drc_text, stage_with_project
from pcbdata.kicad.basics import pcbnew_module as _pcbnew
from pcbdata.kicad.drc_report import NO_NET, parse_drc_report

STEM = "scored"
#: Transplanted items get UUIDs from this seed, so a board gets the same UUIDs in any worker.
UUID_SEED = 20241229
#: Heads of top-level board-file blocks that are organisation, not content (their members are
#: compared on their own), or the writer's identity.
_IGNORED_BLOCKS = ("version", "generator", "generator_version", "group", "generated")
_DRAWINGS = ("gr_", "dimension", "target", "image", "barcode", "table")
_UUID = re.compile(r'\s*\((?:uuid|tstamp) [^()]*\)')
_NET_NUMBER = re.compile(r'\(net \d+ "')
_BARE_NET_NUMBER = re.compile(r'\s*\(net \d+\)')
_FILL_STATE = re.compile(r'\(fill yes\b')
_SPACES = re.compile(r'\s+')
_HEAD = re.compile(r'\(([^\s()]+)')
_BRACKET = re.compile(r'"(?:[^"\\]|\\.)*"|[()]')
_ATOM = re.compile(r'"(?:[^"\\]|\\.)*"|[^\s"]+')
_REFERENCE = re.compile(r'\(property "Reference" "((?:[^"\\]|\\.)*)"')
_LAYER = re.compile(r'\(layer "((?:[^"\\]|\\.)*)"')
#: How far (nm) a centre line may run past the board outline before the rollout is invalid;
#: closer copper is the DRC's (copper_edge_clearance). Real boards run tracks onto edge pads
#: past the cut: a D3-A reference board's track ends 0.5 mm beyond its edge.
OUTLINE_MARGIN = 1_000_000
#: How far (nm) an arc's polyline may stray from the arc in the outline check.
ARC_TOLERANCE = 1_000
_OFF_LAYER = "is on a layer the instance has no copper on"


def stage_board(board_path: str, instance_dir: str, tmp: str) -> str:
    """Copies `board_path` into `tmp` next to copies of the instance's `board.kicad_pro` (and
    `board.kicad_dru`), all under one stem, so KiCad loads the board with the instance's rules
    and never with files that came with a submission."""
    rules = os.path.join(instance_dir, RULES_FILE)
    return stage_with_project(board_path, os.path.join(instance_dir, PROJECT_FILE),
                              rules if os.path.isfile(rules) else None, tmp, stem=STEM)


def _load_staged(board_path: str, instance_dir: str, folder: str):
    """Loads a board staged in its own folder (KiCad keys projects by path, so the two boards
    of a measurement never share a project object)."""
    os.makedirs(folder)
    board = _pcbnew().LoadBoard(stage_board(board_path, instance_dir, folder))
    if board is None:
        raise ValueError("pcbnew.LoadBoard returned no board")
    return board


# ---- copper: read from the submission, rebuilt on the instance --------------------------------

def _xy(point) -> list[int]:
    return [int(point.x), int(point.y)]


def copper_items(board) -> list[dict]:
    """The submission's tracks, arcs and vias as plain data: only what is transplanted."""
    pcbnew = _pcbnew()
    items = []
    for track in board.GetTracks():
        kind = track.Type()
        item: dict = {"net": str(track.GetNetname())}
        if kind == pcbnew.PCB_VIA_T:
            copper = track.GetLayerSet().CuStack()
            item.update(kind="via", at=_xy(track.GetPosition()), via_type=int(track.GetViaType()),
                        top=int(track.TopLayer()), bottom=int(track.BottomLayer()),
                        drill=int(track.GetDrillValue()),
                        widths=sorted({int(track.GetWidth(layer)) for layer in copper}))
        else:
            item.update(kind="arc" if kind == pcbnew.PCB_ARC_T else "track",
                        start=_xy(track.GetStart()), end=_xy(track.GetEnd()),
                        width=int(track.GetWidth()), layer=int(track.GetLayer()))
            if kind == pcbnew.PCB_ARC_T:
                item["mid"] = _xy(track.GetMid())
        items.append(item)
    return items


def _where(item: dict) -> str:
    x, y = item.get("at") or item["start"]
    return f"{item['kind']} at ({x / 1e6:g}, {y / 1e6:g}) mm"


def copper_problem(item: dict, board) -> str | None:
    """Why a submitted track, arc or via cannot stand on the instance's board (a net it lacks,
    a layer it has no copper on, a via with different sizes on different layers), or None."""
    pcbnew = _pcbnew()
    layers = [item["top"], item["bottom"]] if item["kind"] == "via" else [item["layer"]]
    if item["net"] and board.FindNet(item["net"]) is None:
        return f"{_where(item)} is on net {item['net']!r}, which the instance lacks"
    if any(not pcbnew.IsCopperLayer(layer) or not board.IsLayerEnabled(layer) for layer in layers):
        names = ", ".join(str(board.GetLayerName(layer)) for layer in layers)
        return f"{_where(item)} {_OFF_LAYER} ({names})"
    if item["kind"] == "via" and len(item["widths"]) != 1:
        return f"{_where(item)} has different sizes on different layers"
    return None


def copper_problems(items: list[dict], board) -> list[str]:
    return [p for p in (copper_problem(item, board) for item in items) if p is not None]


def _vector(xy: list[int]):
    return _pcbnew().VECTOR2I(int(xy[0]), int(xy[1]))


def _new_item(item: dict, board):
    pcbnew = _pcbnew()
    if item["kind"] == "via":
        via = pcbnew.PCB_VIA(board)
        via.SetPosition(_vector(item["at"]))
        via.SetViaType(item["via_type"])
        via.SetLayerPair(item["top"], item["bottom"])
        via.SetWidth(item["widths"][0])
        via.SetDrill(item["drill"])
        return via
    track = pcbnew.PCB_ARC(board) if item["kind"] == "arc" else pcbnew.PCB_TRACK(board)
    track.SetStart(_vector(item["start"]))
    if item["kind"] == "arc":
        track.SetMid(_vector(item["mid"]))
    track.SetEnd(_vector(item["end"]))
    track.SetWidth(item["width"])
    track.SetLayer(item["layer"])
    return track


def transplant(items: list[dict], board) -> None:
    """Replaces the board's tracks, arcs and vias by `items`, but for those with a
    `copper_problem` (the rollout is invalid then)."""
    pcbnew = _pcbnew()
    for old in list(board.GetTracks()):
        board.Delete(old)
    pcbnew.KIID.SeedGenerator(UUID_SEED)
    for item in items:
        if copper_problem(item, board) is None:
            new = _new_item(item, board)
            new.SetNet(board.FindNet(item["net"]))
            board.Add(new)
    board.BuildConnectivity()


# ---- integrity: everything but copper, as KiCad loaded it -------------------------------------

def _children(text: str) -> tuple[list[str], list[str]]:
    """(atoms, child blocks) of the s-expression `text` = '(head atom ... (child) ...)',
    without the head. Only brackets and strings are visited: boards are long."""
    gaps, children, depth, start = [], [], 0, 0
    for token in _BRACKET.finditer(text):
        value = token.group()
        if value == "(":
            depth += 1
            if depth == 1:
                start = token.end()
            elif depth == 2:
                gaps.append(text[start:token.start()])
                start = token.start()
        elif value == ")":
            if depth == 2:
                children.append(text[start:token.end()])
                start = token.end()
            elif depth == 1:
                gaps.append(text[start:token.start()])
            depth -= 1
    return _ATOM.findall(" ".join(gaps))[1:], children


def _head(block: str) -> str:
    match = _HEAD.match(block)
    return match.group(1) if match else ""


def _without_blocks(text: str, head: str) -> str:
    """`text` without every block `(head ...)` (at any depth)."""
    out, start = [], 0
    while (found := text.find(f"({head}", start)) >= 0:
        out.append(text[start:found])
        start = block_end(text, found)
    return "".join(out) + text[start:]


def _normal(block: str) -> str:
    """A block as KiCad wrote it, without what a rewrite may change: UUIDs, net numbers
    (nets are compared by name), zone fills (fills come from the instance) and layout."""
    text = _UUID.sub("", block)
    text = _BARE_NET_NUMBER.sub("", _NET_NUMBER.sub('(net "', text))
    text = _FILL_STATE.sub("(fill", _without_blocks(text, "filled_polygon"))
    return _SPACES.sub(" ", text).replace(" )", ")").replace("( ", "(").strip()


def _entry(key: str, atoms: list[str], children: list[str]) -> str:
    """`key|atom|...|child|...` with the children sorted: a rewrite may reorder them."""
    return "|".join([key, *atoms, *sorted(children)])


def _first(pattern: re.Pattern, block: str) -> str:
    match = pattern.search(block)
    return match.group(1) if match else ""


def _zone_key(children: list[str]) -> str:
    """`zone NET1 on F.Cu`, `rule area 'keepout' on F.Cu B.Cu`."""
    fields = {_head(c): c[len(_head(c)) + 1:-1].strip().replace('"', "") for c in children}
    layers = fields.get("layers") or fields.get("layer", "")
    if "keepout" in fields:
        return f"rule area {fields.get('name', '')!r} on {layers}"
    return f"zone {fields.get('net_name') or 'without net'} on {layers}"


def _footprint_entries(block: str, out: dict[str, list[str]]) -> None:
    """The footprint without its pads, and each pad on its own (`REF:number`)."""
    ref = _first(_REFERENCE, block)
    atoms, children = _children(block)
    pads = [c for c in children if _head(c) == "pad"]
    out["footprints"].append(_entry(ref, atoms, [c for c in children if _head(c) != "pad"]))
    for pad in pads:
        pad_atoms, pad_children = _children(pad)
        number = pad_atoms[0].strip('"') if pad_atoms else ""
        out["pads"].append(_entry(f"{ref}:{number}", pad_atoms, pad_children))


def file_fingerprint(text: str) -> dict[str, list[str]]:
    """Per category, sorted entries `key|part|...` of a board file KiCad wrote without copper."""
    out: dict[str, list[str]] = {k: [] for k in ("footprints", "pads", "zones", "outline",
                                                 "drawings", "setup")}
    for block in _children(text)[1]:
        head, block = _head(block), _normal(block)
        if head in _IGNORED_BLOCKS or head == "net":  # nets: from the board, not the file
            continue
        if head == "footprint":
            _footprint_entries(block, out)
            continue
        atoms, children = _children(block)
        if head == "zone":
            out["zones"].append(_entry(_zone_key(children), atoms, children))
        elif head.startswith(_DRAWINGS):
            layer = _first(_LAYER, block)
            category = "outline" if layer == "Edge.Cuts" else "drawings"
            out[category].append(_entry(f"{head} on {layer}", atoms, children))
        else:
            out["setup"].append(_entry(head, atoms, children))
    return {k: sorted(v) for k, v in out.items()}


def _value(value) -> str:
    if isinstance(value, float):
        return repr(value)
    return str(value)


#: NETCLASS parameters the DRC can use, by getter stem (`Get<stem>Opt` when KiCad has it).
_NETCLASS_FIELDS = ("Clearance", "TrackWidth", "ViaDiameter", "ViaDrill", "uViaDiameter",
                    "uViaDrill", "DiffPairWidth", "DiffPairGap", "DiffPairViaGap", "Priority")


def _netclass_entry(netclass) -> str:
    parts = [str(netclass.GetName())]
    for field in _NETCLASS_FIELDS:
        getter = getattr(netclass, f"Get{field}Opt", None) or getattr(netclass, f"Get{field}")
        parts.append(f"{field}={_value(getter())}")
    return "|".join(parts)


def netclass_fingerprint(board) -> list[str]:
    """Every net class with its parameters, and the class each net resolves to."""
    settings = board.GetDesignSettings().m_NetSettings
    classes = [settings.GetDefaultNetclass()] + [nc for _, nc in settings.GetNetclasses().items()]
    entries = [f"class {_netclass_entry(nc)}" for nc in classes]
    for name in sorted(str(n) for n in board.GetNetsByName().keys() if str(n)):
        effective = settings.GetEffectiveNetClass(name)
        entries.append(f"net {name}|{_netclass_entry(effective)}")
    return sorted(entries)


#: What KiCad records when a board file carries rules of its own (it then obeys them).
_LEGACY_FLAGS = (("board file carries legacy design settings", "m_LegacyDesignSettingsLoaded"),
                 ("board file carries legacy net classes", "m_LegacyNetclassesLoaded"),
                 ("board file carries a legacy edge clearance",
                  "m_LegacyCopperEdgeClearanceLoaded"))


def rules_fingerprint(board) -> list[str]:
    """The design settings as the loaded board resolves them (scalars of KiCad's
    BOARD_DESIGN_SETTINGS), DRC exclusions, and whether the file carried legacy rules (KiCad
    then obeys the board file instead of the project)."""
    settings = board.GetDesignSettings()
    entries = [f"{key}|{_value(getattr(board, name))}" for key, name in _LEGACY_FLAGS]
    for name in dir(settings):
        value = getattr(settings, name) if name.startswith("m_") else None
        if isinstance(value, (bool, int, float, str)):
            entries.append(f"{name}|{_value(value)}")
    exclusions = sorted(str(e) for e in settings.m_DrcExclusions)
    entries.append("m_DrcExclusions|" + (";".join(exclusions) or "none"))
    entries.append(f"board thickness|{settings.GetBoardThickness()}")
    return sorted(entries)


def _all_zones(board):
    yield from board.Zones()
    for footprint in board.GetFootprints():
        yield from footprint.Zones()


def fingerprint(board, folder: str) -> dict[str, list[str]]:
    """Everything a submission must not change, per category, as sorted lists of strings: the
    board as KiCad writes it without its tracks, arcs and vias (nets, footprints with every
    local override, pads, zones with their settings, outline, drawings, layers and setup), the
    net classes and the design rules as the board resolves them. Deletes the board's copper."""
    for track in list(board.GetTracks()):
        board.Delete(track)
    for zone in _all_zones(board):
        zone.UnFill()  # fills follow the copper; the instance's are used
    path = os.path.join(folder, "fingerprint.kicad_pcb")
    _pcbnew().PCB_IO_KICAD_SEXPR().SaveBoard(path, board)
    with open(path, encoding="utf-8", errors="replace") as handle:
        result = file_fingerprint(handle.read())
    result["nets"] = sorted(str(n) for n in board.GetNetsByName().keys() if str(n))
    result["netclasses"] = netclass_fingerprint(board)
    result["rules"] = rules_fingerprint(board)
    return result


# ---- measurements on the transplanted board ---------------------------------------------------

def item_keys(items: list) -> tuple[list[str], list[int]]:
    """Each item's KiCad id and net code."""
    return [item.m_Uuid.AsString() for item in items], [item.GetNetCode() for item in items]


def copper_labels(board, items: list, memory: dict | None = None,
                  keys: tuple[list[str], list[int]] | None = None) -> list[int]:
    """A cluster label per item of `items` (pads, tracks, vias, zones): items with one label
    are joined by copper of their net, as KiCad's connectivity links them. Labels count up in
    `items` order; an item without a net gets a label of its own.

    Every link touches a track, via or zone, except pad-to-pad contact: tracks and zones ask
    for both kinds of neighbours, pads only for pads (the same links, found once).

    `memory` (a dict kept between calls on one board whose items are only ever added and
    deleted, never moved) remembers, by KiCad id, what pads, tracks and vias asked and their
    net then: a link between two items does not change while both stand on their nets, and
    one to a newer item is found when the newer item asks, so only new items, items whose net
    changed (KiCad gives net-less copper the net of a pad it touches) and zones (whose links
    reach new tracks from their side only) ask KiCad again; the labels are the same. A board
    whose items do not have distinct ids asks for everything. `keys`: the items' `item_keys`,
    where the caller has them already."""
    pcbnew = _pcbnew()
    conn = board.GetConnectivity()
    ids, nets = keys if keys is not None else item_keys(items)
    index = {uid: i for i, uid in enumerate(ids)}
    if len(index) != len(items):
        memory = None
    kept = (pcbnew.PCB_PAD_T, pcbnew.PCB_TRACE_T, pcbnew.PCB_VIA_T, pcbnew.PCB_ARC_T)
    parent = list(range(len(items)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, item in enumerate(items):
        known = memory.get(ids[i]) if memory is not None else None
        if known is not None and known[0] == nets[i]:
            linked = known[1]
        else:
            linked = _linked(conn, pcbnew, item, nets[i])
            if memory is not None and item.Type() in kept:
                memory[ids[i]] = (nets[i], linked)
        for uid in linked:
            j = index.get(uid)
            if j is not None and nets[j] == nets[i]:
                parent[find(i)] = find(j)
    labels: dict[int, int] = {}
    return [labels.setdefault(find(i), len(labels)) for i in range(len(items))]


def _linked(conn, pcbnew, item, net: int) -> tuple[str, ...]:
    """The ids of the items of its net (`net`) that KiCad's connectivity links `item` to (pads
    for every item, tracks and vias for all but pads); none for an item without a net."""
    if net <= 0:
        return ()
    neighbours = list(conn.GetConnectedPads(item))
    if item.Type() != pcbnew.PCB_PAD_T:
        neighbours += list(conn.GetConnectedTracks(item))
    return tuple(other.m_Uuid.AsString() for other in neighbours if other.GetNetCode() == net)


def clusters_per_net(pads: list, pad_labels: list[int]) -> dict[str, int]:
    """Per net name: how many distinct copper clusters (`copper_labels` of the pads) hold its
    pads; pads without a net are left out."""
    clusters: dict[str, set[int]] = {}
    for pad, label in zip(pads, pad_labels):
        if pad.GetNetCode() > 0:
            clusters.setdefault(str(pad.GetNetname()), set()).add(label)
    return {net: len(labels) for net, labels in sorted(clusters.items())}


def pad_clusters(board) -> dict[str, int]:
    """Per net name: the number of connected copper clusters of that net holding >= 1 pad."""
    pads = list(board.GetPads())
    labels = copper_labels(board, pads + list(board.GetTracks()) + list(board.Zones()))
    return clusters_per_net(pads, labels[: len(pads)])


def copper_totals(board) -> tuple[float, int]:
    """(total length of track segments and arcs in mm, number of vias) of the board's copper
    (`totals_of`)."""
    pcbnew = _pcbnew()
    kinds = {pcbnew.PCB_VIA_T: "via", pcbnew.PCB_ARC_T: "arc", pcbnew.PCB_TRACE_T: "track"}
    shapes: list[tuple] = []
    for track in board.GetTracks():
        kind = kinds.get(track.Type())
        if kind == "via":
            shapes.append(("via", None, None, None))
        elif kind is not None:
            shapes.append((kind, _xy(track.GetStart()), _xy(track.GetEnd()),
                           _xy(track.GetMid()) if kind == "arc" else None))
    return totals_of(shapes)


def totals_of(shapes) -> tuple[float, int]:
    """(total length in mm, number of vias) of (kind, start, end, mid) shapes in nm, kind
    "track", "arc" or "via". Lengths are geometric (an arc from its three points,
    `copper_geometry.arc_length`, never KiCad's `GetLength()`, which is wrong for nearly
    straight arcs) and summed exactly (fsum), so the order of the tracks cannot change the
    last digit."""
    lengths, vias = [], 0
    for kind, start, end, mid in shapes:
        if kind == "via":
            vias += 1
        elif kind == "arc":
            lengths.append(arc_length(start, mid, end))
        else:
            lengths.append(math.dist(start, end))
    return math.fsum(lengths) / 1e6, vias


_SECTIONS = {"violations": 0, "unconnected": 1, "footprint": 2}


def violation_order(violation: dict) -> tuple:
    """The canonical order of DRC violations: section, type, severity, positions, nets, message,
    item descriptions. KiCad's DRC runs in threads and reports in no fixed order."""
    return (_SECTIONS.get(violation["section"], 3), violation["type"], violation["severity"],
            violation["positions"], violation["nets"], violation["message"], violation["items"])


def violation_records(report) -> list[dict]:
    """A parsed DRC report as plain violations, each with its items sorted, in the canonical
    order (`violation_order`)."""
    records = []
    for v in report.violations:
        items = sorted(v.items, key=lambda i: (i.x_mm, i.y_mm, i.description))
        records.append({"type": v.type, "severity": v.severity, "section": v.section,
                        "rule": v.rule, "message": v.message, "nets": v.nets,
                        "no_net_item": any(i.net is None or i.net == NO_NET for i in items),
                        "positions": [[i.x_mm, i.y_mm] for i in items],
                        "items": [i.description for i in items]})
    return sorted(records, key=violation_order)


def drc_violations(board) -> list[dict]:
    """KiCad DRC (all severities, all track errors), canonically ordered (`violation_records`)."""
    return violation_records(parse_drc_report(board_drc_text(board)))


def measure(board_path: str, instance_dir: str) -> dict:
    """Every raw measurement the evaluator needs for `board_path` scored on the instance in
    `instance_dir`: the fingerprint of the submitted board and the problems of its copper (as
    the file holds it and as KiCad loaded it), and, on the instance's board with that copper
    transplanted, the DRC violations, pad clusters per net, WL, vias and net count."""
    with open(board_path, "rb") as handle:
        in_file = copper_in_file(handle.read())  # before KiCad drops or clamps anything
    with tempfile.TemporaryDirectory(prefix="pcbdata-score-") as tmp:
        try:
            submitted = _load_staged(board_path, instance_dir, os.path.join(tmp, "submitted"))
        except Exception as exc:  # noqa: BLE001 - KiCad raises IOError with a parser message
            return {"loaded": False, "reason": f"KiCad could not load the board: {exc}".strip()}
        return _measure_loaded(submitted, in_file, instance_dir, tmp)


def copper_layer_names(board) -> set[str]:
    """Every name the board's enabled copper layers go by (standard and user names)."""
    pcbnew = _pcbnew()
    layers = board.GetEnabledLayers().CuStack()
    return ({str(pcbnew.BOARD.GetStandardLayerName(layer)) for layer in layers}
            | {str(board.GetLayerName(layer)) for layer in layers})


def board_polygons(board) -> list[tuple[list[list[int]], list[list[list[int]]]]]:
    """The board outline as (outer ring, holes) pairs in nm; KiCad's fallback (a box around
    the board's items) when Edge.Cuts is not a closed shape."""
    polys = _pcbnew().SHAPE_POLY_SET()
    board.GetBoardPolygonOutlines(polys)

    def ring(chain) -> list[list[int]]:
        return [_xy(chain.CPoint(i)) for i in range(chain.PointCount())]

    return [(ring(polys.COutline(i)), [ring(polys.CHole(i, h)) for h in range(polys.HoleCount(i))])
            for i in range(polys.OutlineCount())]


def _path_text(item: dict) -> str:
    if item["kind"] == "via":
        return _where(item)
    ends = " - ".join(f"({x / 1e6:g}, {y / 1e6:g})" for x, y in (item["start"], item["end"]))
    return f"{item['kind']} {ends} mm"


def outline_problem(items: list[dict], board) -> str | None:
    """Copper whose centre line runs more than `OUTLINE_MARGIN` past the instance's board
    outline (a track to x = -1e9 mm is clamped by KiCad to about -2.1 m and raises no
    edge-clearance violation)."""
    shape = outline_shape(board_polygons(board), OUTLINE_MARGIN)
    outside = items_outside(items, shape, ARC_TOLERANCE)
    if not outside:
        return None
    more = f" (and {len(outside) - 1} more)" if len(outside) > 1 else ""
    return (f"{_path_text(items[outside[0]])} leaves the board outline (by more than "
            f"{OUTLINE_MARGIN / 1e6:g} mm){more}")


def dropped_problems(in_file: list[dict], loaded: list[dict]) -> list[str]:
    """Items of the file that KiCad did not load (per kind)."""
    found, kept = kind_counts(in_file), kind_counts(loaded)
    return [f"KiCad loaded {kept[kind]} of the file's {count} {kind}s (it dropped the others)"
            for kind, count in found.items() if kept[kind] != count]


def submission_problems(in_file: list[dict], items: list[dict], board) -> list[str]:
    """Every reason the submission's copper cannot be scored on the instance's `board`: its
    file's own items (coordinates beyond KiCad's range, layers without copper), items KiCad
    dropped, copper KiCad loaded that cannot stand on the instance, copper off the board."""
    from_file = file_problems(in_file, copper_layer_names(board))
    loaded = copper_problems(items, board)
    if any(_OFF_LAYER in p for p in from_file):  # the file names them all, KiCad's survivors too
        loaded = [p for p in loaded if _OFF_LAYER not in p]
    standing = [item for item in items if copper_problem(item, board) is None]
    problems = from_file + dropped_problems(in_file, items) + loaded
    problems.append(outline_problem(standing, board) or "")
    return [p for p in problems if p]


def _measure_loaded(submitted, in_file: list[dict], instance_dir: str, tmp: str) -> dict:
    items = copper_items(submitted)
    board = _load_staged(os.path.join(instance_dir, BOARD_FILE), instance_dir,
                         os.path.join(tmp, "instance"))
    problems = submission_problems(in_file, items, board)
    transplant(items, board)
    wl, vias = copper_totals(board)
    return {
        "loaded": True,
        "net_count": int(board.GetNetCount()),
        "clusters": pad_clusters(board),
        "wl_mm": wl,
        "vias": vias,
        "copper_problems": problems,
        "fingerprint": fingerprint(submitted, tmp),
        "violations": drc_violations(board),
    }

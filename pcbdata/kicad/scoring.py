"""The KiCad side of the evaluator: measures one board file with an instance's own rules.

Runs inside engine worker processes only (`pcbdata.kicad.pool.KicadPool`). Every function
returns plain data; the metrics themselves (DRC buckets, routability, potential, integrity) are
computed from these measurements by the pure modules of `pcbdata.evaluator`.
"""
from __future__ import annotations

import os
import tempfile

from pcbdata.kicad.drc_report import parse_drc_report
from pcbdata.kicad.basics import board_drc_text, pcbnew_module as _pcbnew, stage_with_project

#: Design settings stored in the `.kicad_pcb` itself (its `setup` section): a submission must
#: not change them (e.g. a larger solder-mask expansion hides solder_mask_bridge errors).
BOARD_FILE_RULES = ("m_SolderMaskExpansion", "m_SolderMaskMinWidth",
                    "m_SolderMaskToCopperClearance", "m_AllowSoldermaskBridgesInFPs",
                    "m_SolderPasteMargin", "m_SolderPasteMarginRatio", "m_TentViasFront",
                    "m_TentViasBack")


def stage_board(board_path: str, instance_dir: str, tmp: str) -> str:
    """Copies `board_path` into `tmp` next to copies of the instance's `board.kicad_pro` (and
    `board.kicad_dru`), all under one stem, so KiCad loads the board with the instance's rules
    and never with files that came with a submission."""
    rules = os.path.join(instance_dir, "board.kicad_dru")
    return stage_with_project(board_path, os.path.join(instance_dir, "board.kicad_pro"),
                              rules if os.path.isfile(rules) else None, tmp, stem="scored")


def _xy(point) -> str:
    return f"{int(point.x)},{int(point.y)}"


def _layers(item) -> str:
    return ",".join(sorted(str(n) for n in item.GetLayerSet().Seq()))


def fingerprint(board) -> dict[str, list[str]]:
    """Everything a submission must not change, per category, as sorted lists of strings."""
    pcbnew = _pcbnew()
    nets = sorted(str(n) for n in board.GetNetsByName().keys() if str(n))
    footprints, pads = [], []
    for fp in board.GetFootprints():
        ref = fp.GetReference()
        footprints.append(f"{ref}|{fp.GetFPIDAsString()}|{_xy(fp.GetPosition())}|"
                          f"{fp.GetOrientationDegrees():g}|{fp.GetLayer()}")
        for pad in fp.Pads():
            size = _pad_size(pad)
            drill = pad.GetDrillSize()
            pads.append(f"{ref}:{pad.GetNumber()}|{_xy(pad.GetPosition())}|"
                        f"{pad.GetOrientationDegrees():g}|{pad.ShowPadShape(pcbnew.F_Cu)}|"
                        f"{int(size.x)},{int(size.y)}|{int(drill.x)},{int(drill.y)}|"
                        f"{_layers(pad)}|{pad.GetNetname()}")
    zones = []
    for zone in board.Zones():
        outline = zone.Outline()
        points = ";".join(_xy(outline.CVertex(i)) for i in range(outline.TotalVertices()))
        zones.append(f"{zone.GetNetname()}|{_layers(zone)}|{zone.GetIsRuleArea()}|"
                     f"{zone.GetAssignedPriority()}|{points}")
    outline, copper_drawings = [], []
    edge = board.GetLayerID("Edge.Cuts")
    for drawing in board.GetDrawings():
        layer = drawing.GetLayer()
        if layer != edge and not pcbnew.IsCopperLayer(layer):
            continue
        text = f"{drawing.GetClass()}|{layer}|{_xy(drawing.GetPosition())}"
        if hasattr(drawing, "GetShape") and drawing.GetClass() == "PCB_SHAPE":
            text += f"|{drawing.GetShape()}|{_xy(drawing.GetStart())}|{_xy(drawing.GetEnd())}"
            if drawing.GetShape() == pcbnew.SHAPE_T_ARC:
                text += f"|{_xy(drawing.GetArcMid())}"
            elif drawing.GetShape() == pcbnew.SHAPE_T_POLY:
                poly = drawing.GetPolyShape()
                text += "|" + ";".join(_xy(poly.CVertex(i)) for i in range(poly.TotalVertices()))
        (outline if layer == edge else copper_drawings).append(text)
    rules = [f"copper_layers={board.GetCopperLayerCount()}",
             f"enabled_layers={','.join(str(n) for n in board.GetEnabledLayers().Seq())}"]
    settings = board.GetDesignSettings()  # the rules a board file (not its project) carries
    for name in BOARD_FILE_RULES:
        if hasattr(settings, name):
            rules.append(f"{name}={getattr(settings, name)}")
    rules.append(f"thickness={settings.GetBoardThickness()}")
    return {"nets": nets, "footprints": sorted(footprints), "pads": sorted(pads),
            "zones": sorted(zones), "outline": sorted(outline),
            "copper_drawings": sorted(copper_drawings), "rules": rules}


def _pad_size(pad):
    """KiCad 9 pads have per-layer sizes (`GetSize(layer)`); older bindings take no layer."""
    try:
        return pad.GetSize(pad.GetPrincipalLayer())
    except TypeError:
        return pad.GetSize()


def pad_clusters(board) -> dict[str, int]:
    """Per net name: the number of connected copper clusters of that net holding >= 1 pad."""
    conn = board.GetConnectivity()  # built by LoadBoard
    parent: dict[str, str] = {}

    def find(key: str) -> str:
        root = key
        while parent.get(root, root) != root:
            root = parent[root]
        while parent.get(key, key) != root:
            parent[key], key = root, parent[key]
        return root

    def union(a: str, b: str) -> None:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb

    # Every link touches a track, via or zone, except pad-to-pad contact: tracks and zones ask
    # for both kinds of neighbours, pads only for pads.
    items = [(item, True) for item in list(board.GetTracks()) + list(board.Zones())]
    items += [(pad, False) for pad in board.GetPads()]
    for item, any_kind in items:
        net = item.GetNetCode()
        if net <= 0:
            continue
        key = item.m_Uuid.AsString()
        neighbours = list(conn.GetConnectedPads(item))
        if any_kind:
            neighbours += list(conn.GetConnectedTracks(item))
        for other in neighbours:
            if other.GetNetCode() == net:
                union(key, other.m_Uuid.AsString())
    clusters: dict[str, set[str]] = {}
    for pad in board.GetPads():
        if pad.GetNetCode() <= 0:
            continue
        clusters.setdefault(pad.GetNetname(), set()).add(find(pad.m_Uuid.AsString()))
    return {net: len(roots) for net, roots in sorted(clusters.items())}


def copper_totals(board) -> tuple[float, int]:
    """(total length of track segments and arcs in mm, number of vias)."""
    pcbnew = _pcbnew()
    length_nm, vias = 0.0, 0
    for track in board.GetTracks():
        kind = track.Type()
        if kind == pcbnew.PCB_VIA_T:
            vias += 1
        elif kind in (pcbnew.PCB_TRACE_T, pcbnew.PCB_ARC_T):
            length_nm += track.GetLength()  # an arc's length is its arc length
    return length_nm / 1e6, vias


def drc_violations(board) -> list[dict]:
    """KiCad DRC (all severities, all track errors) as a list of
    {type, severity, section, nets} dicts."""
    parsed = parse_drc_report(board_drc_text(board))
    return [{"type": v.type, "severity": v.severity, "section": v.section, "nets": v.nets,
             "no_net_item": any(i.net is None or i.net == "<no net>" for i in v.items)}
            for v in parsed.violations]


def measure(board_path: str, instance_dir: str) -> dict:
    """Loads `board_path` with the instance's project and returns every raw measurement the
    evaluator needs: DRC violations, pad clusters per net, WL, vias, net count, fingerprint."""
    pcbnew = _pcbnew()
    with tempfile.TemporaryDirectory(prefix="pcbdata-score-") as tmp:
        staged = stage_board(board_path, instance_dir, tmp)
        try:
            board = pcbnew.LoadBoard(staged)
        except Exception as exc:  # noqa: BLE001 - KiCad raises IOError with a parser message
            return {"loaded": False, "reason": f"KiCad could not load the board: {exc}".strip()}
        if board is None:
            return {"loaded": False, "reason": "KiCad could not load the board"}
        wl, vias = copper_totals(board)
        return {
            "loaded": True,
            "net_count": int(board.GetNetCount()),
            "clusters": pad_clusters(board),
            "wl_mm": wl,
            "vias": vias,
            "fingerprint": fingerprint(board),
            "violations": drc_violations(board),
        }

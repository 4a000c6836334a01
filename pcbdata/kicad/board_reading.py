"""A loaded KiCad board read out as plain records (integer nanometres, layer and net names):
outline, net rules, pads with their copper polygons, zones, copper drawings and texts, tracks
and vias, and DRC violations with positions. The routing session (`routing_session`) and the
pictures (`board_records`) read boards the same way. Worker side only."""
from __future__ import annotations

from pcbdata.kicad.basics import board_drc_text
from pcbdata.kicad.basics import pcbnew_module as _pcbnew
from pcbdata.kicad.drc_report import parse_drc_report


def ring(chain) -> list[tuple[int, int]]:
    return [(int(chain.CPoint(i).x), int(chain.CPoint(i).y)) for i in range(chain.PointCount())]


def outline_rings(board) -> list[list[tuple[int, int]]]:
    """Board outline rings (outer boundaries first, then holes), nm."""
    polys = _pcbnew().SHAPE_POLY_SET()
    if not board.GetBoardPolygonOutlines(polys):
        raise ValueError("the board outline (Edge.Cuts) is not a closed shape")
    rings = [ring(polys.COutline(i)) for i in range(polys.OutlineCount())]
    for i in range(polys.OutlineCount()):
        rings += [ring(polys.CHole(i, h)) for h in range(polys.HoleCount(i))]
    return rings


def net_rules(board) -> list[dict]:
    """Every net (netcode order) with the rules its netclass resolves to (nm)."""
    settings = board.GetDesignSettings()
    netclasses = settings.m_NetSettings
    out = []
    for code, net in sorted(board.GetNetsByNetcode().items()):
        if code <= 0:
            continue
        nc = netclasses.GetEffectiveNetClass(net.GetNetname())
        out.append({"code": int(code), "name": str(net.GetNetname()),
                    "clearance": max(int(nc.GetClearance()), int(settings.m_MinClearance)),
                    "track_width": max(int(nc.GetTrackWidth()), int(settings.m_TrackMinWidth)),
                    "via_diameter": int(nc.GetViaDiameter()), "via_drill": int(nc.GetViaDrill())})
    return out


def polygon_rings(poly_set) -> list[list[tuple[int, int]]]:
    return [ring(poly_set.COutline(i)) for i in range(poly_set.OutlineCount())]


def pad_record(board, pad, layers: dict[str, int]) -> dict:
    pcbnew = _pcbnew()
    on = [name for name, lid in layers.items() if pad.IsOnLayer(lid)]
    principal = pad.GetPrincipalLayer()
    size = pad.GetSize(principal)
    shapes = {name: polygon_rings(pad.GetEffectivePolygon(layers[name], pcbnew.ERROR_OUTSIDE))
              for name in on}
    return {"net": str(pad.GetNetname()), "x": int(pad.GetPosition().x),
            "y": int(pad.GetPosition().y), "size": (int(size.x), int(size.y)),
            "shape": str(pad.ShowPadShape(principal)), "layers": on,
            "drill": int(pad.GetDrillSize().x), "through_hole": pad.GetDrillSize().x > 0,
            "orientation": float(pad.GetOrientationDegrees()),
            "name": f"{pad.GetParentFootprint().GetReference()}:{pad.GetNumber()}",
            "polygons": shapes, "clearance": local_clearance(pad, pad.GetParentFootprint())}


def local_clearance(*items) -> int:
    """The first clearance override set on `items` (a pad, then its footprint), 0 if none:
    KiCad's DRC uses it for that pad instead of its net class clearance."""
    for item in items:
        value = item.GetLocalClearance()
        if value is not None:
            return int(value)
    return 0


def zone_records(board, layers: dict[str, int]) -> list[dict]:
    out = []
    for zone in board.Zones():
        if zone.GetIsRuleArea():
            continue
        for name, lid in layers.items():
            if zone.IsOnLayer(lid) and zone.HasFilledPolysForLayer(lid):
                for ring in polygon_rings(zone.GetFilledPolysList(lid)):
                    out.append({"net": str(zone.GetNetname()), "layer": name, "polygon": ring})
    return out


def graphic_records(board, layers: dict[str, int]) -> list[dict]:
    """Copper that is neither pad, track nor zone: board and footprint drawings and texts on
    copper layers, as KiCad's own polygons (texts: their box), outlines only (holes filled)."""
    pcbnew = _pcbnew()
    items = list(board.GetDrawings())
    for footprint in board.GetFootprints():
        items += list(footprint.GraphicalItems()) + [footprint.Reference(), footprint.Value()]
    max_error = int(board.GetDesignSettings().m_MaxError)
    out = []
    for item in items:
        if hasattr(item, "IsVisible") and not item.IsVisible():
            continue
        net = str(item.GetNetname()) if hasattr(item, "GetNetname") else ""
        for name, lid in layers.items():
            if not item.IsOnLayer(lid):
                continue
            shape = pcbnew.SHAPE_POLY_SET()
            item.TransformShapeToPolygon(shape, lid, 0, max_error, pcbnew.ERROR_OUTSIDE)
            out += [{"net": net, "layer": name, "polygon": ring} for ring in polygon_rings(shape)
                    if len(ring) >= 3]
    return out


def track_record(item, layer_names: dict[int, str], cluster: int) -> dict:
    pcbnew = _pcbnew()
    record = {"net": str(item.GetNetname()), "cluster": cluster}
    if item.Type() == pcbnew.PCB_VIA_T:
        top, bottom = item.TopLayer(), item.BottomLayer()
        record.update(kind="via", x=int(item.GetPosition().x), y=int(item.GetPosition().y),
                      diameter=int(item.GetWidth(top)), drill=int(item.GetDrillValue()),
                      layers=[layer_names[top], layer_names[bottom]])
        return record
    record.update(kind="arc" if item.Type() == pcbnew.PCB_ARC_T else "track",
                  layer=layer_names.get(item.GetLayer(), ""), width=int(item.GetWidth()),
                  start=(int(item.GetStart().x), int(item.GetStart().y)),
                  end=(int(item.GetEnd().x), int(item.GetEnd().y)))
    if record["kind"] == "arc":
        mid = item.GetMid()
        record["mid"] = (int(mid.x), int(mid.y))
    return record


def located_violations(board) -> list[dict]:
    """KiCad's DRC as `pcbdata.kicad.scoring.drc_violations` gives it, plus the positions of
    the items each violation names (mm, as the report prints them)."""
    parsed = parse_drc_report(board_drc_text(board))
    return [{"type": v.type, "severity": v.severity, "section": v.section, "nets": v.nets,
             "no_net_item": any(i.net is None or i.net == "<no net>" for i in v.items),
             "positions": [(i.x_mm, i.y_mm) for i in v.items]}
            for v in parsed.violations]

"""The routing environment's board, held in a KiCad worker process (worker side only).

A `pcbdata.env` environment owns one `KicadPool` worker; that worker keeps the instance's board
as module-level state between tasks, so each routing step is one round trip: the environment
sends the tracks and vias to add, the worker adds them as real KiCad items of the net and
answers with a snapshot (KiCad's connectivity, copper totals and, when asked, KiCad's DRC under
the instance's own project). Every return value is plain data (integer nanometres, names).

The measurements reuse the evaluator's functions (`pcbdata.kicad.scoring`), so the
environment's Phi is computed from exactly what `pcbdata eval` measures.
"""
from __future__ import annotations

import os
import shutil

from pcbdata.core.copper_geometry import stub_cut
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, RULES_FILE
from pcbdata.kicad.basics import pcbnew_module as _pcbnew
from pcbdata.kicad.board_reading import (
    graphic_records,
    located_violations,
    net_rules,
    outline_rings,
    pad_record,
    polygon_rings,
    track_record,
    zone_records,
)
from pcbdata.kicad.scoring import clusters_per_net, copper_labels, item_keys, totals_of
from pcbdata.kicad.step_drc import is_uncounted_warning, static_violations, step_project_text

#: The one board of this worker: {"board", "layers": {name: id}, "pads": [PAD], "path"}.
_STATE: dict = {}
_STAGED = [0]  # instances staged by this worker: each gets its own folder
#: KiCad mints random UUIDs (for the items it adds at load, such as footprint properties the
#: file lacks, and for new tracks and vias): loading seeds them with UUID_SEED and the n-th
#: `apply` of an episode with UUID_SEED + n, so a saved board is the same bytes in any worker,
#: whatever the worker ran before.
UUID_SEED = 20250301



def _board():
    if "board" not in _STATE:
        raise RuntimeError("no board is open in this worker (open_instance first)")
    return _STATE["board"]


def _stage(board: str, project: str, rules: str | None, stage_dir: str) -> str:
    """Copies the instance's files under one stem into a new folder of the environment's
    private folder: KiCad loads the rules that share the board's stem and writes lock files
    beside it. The folder is new for every staging because KiCad keeps a project it has loaded
    by its path: a second board staged at the same path would get the first board's rules."""
    folder = _new_folder(stage_dir)
    staged = os.path.join(folder, BOARD_FILE)
    shutil.copyfile(board, staged)
    shutil.copyfile(project, os.path.join(folder, PROJECT_FILE))
    if rules:
        shutil.copyfile(rules, os.path.join(folder, RULES_FILE))
    return staged


def _new_folder(stage_dir: str) -> str:
    os.makedirs(stage_dir, exist_ok=True)
    _STAGED[0] += 1
    folder = os.path.join(stage_dir, str(_STAGED[0]))
    os.makedirs(folder)
    return folder


def _clear(stage_dir: str) -> None:
    """Removes the previous instance's staged folders."""
    if os.path.isdir(stage_dir):
        for name in os.listdir(stage_dir):
            shutil.rmtree(os.path.join(stage_dir, name), ignore_errors=True)


def _load(staged: str, board: str):
    loaded = _pcbnew().LoadBoard(staged)
    if loaded is None:
        raise ValueError(f"{board}: KiCad could not load the board")
    loaded.BuildConnectivity()
    return loaded


def _read(path: str) -> str:
    with open(path, encoding="utf-8", errors="replace") as handle:
        return handle.read()


def open_instance(board: str, project: str, rules: str | None, stage_dir: str,
                  counted_warnings: list[str]) -> dict:
    """Loads an instance (replacing any board this worker held); returns its static data and
    the first snapshot (with a whole DRC). The DRC leaves out the warnings whose types are not
    in `counted_warnings`.

    After that first DRC the board is put under a copy of the project that ignores the static
    checks and those warnings (`pcbdata.kicad.step_drc`); the static checks' violations of the
    first DRC are added to every later one."""
    pcbnew = _pcbnew()
    _STATE.clear()
    _clear(stage_dir)
    pcbnew.BOARD()  # a process's first BOARD draws one UUID (a static item): not after the seed
    pcbnew.KIID.SeedGenerator(UUID_SEED)
    loaded = _load(_stage(board, project, rules, stage_dir), board)
    layers = {loaded.GetLayerName(i): int(i) for i in loaded.GetEnabledLayers().CuStack()}
    _STATE.update(board=loaded, layers=layers, pads=list(loaded.GetPads()), applies=1,
                  counted_warnings=frozenset(counted_warnings), static_violations=[],
                  links={}, records={})
    first = snapshot(True)
    step_text = step_project_text(_read(project), _STATE["counted_warnings"],
                                  _read(rules) if rules else None)
    if step_text is not None:
        _STATE["static_violations"] = static_violations(first["violations"])
        _use_project(loaded, step_text, stage_dir)
        _STATE.update(links={}, records={})  # asked again under the step project
    return {"static": _static(loaded), "snapshot": first}


def _use_project(board, project_text: str, stage_dir: str) -> None:
    """Puts the board under another project (as `LoadBoard` puts a board under its own): the
    design settings, severities included, are read from it; the rules stay the board's."""
    pcbnew = _pcbnew()
    path = os.path.join(_new_folder(stage_dir), PROJECT_FILE)
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(project_text)
    settings = pcbnew.GetSettingsManager()
    if not settings.LoadProject(path, False):
        raise RuntimeError(f"{path}: KiCad could not load the step project")
    board.SetProject(settings.GetProject(path))
    board.SynchronizeNetsAndNetClasses(False)


def _static(board) -> dict:
    settings = board.GetDesignSettings()
    layers = _STATE["layers"]
    return {"layers": list(layers), "outline": outline_rings(board), "nets": net_rules(board),
            "pads": [pad_record(board, p, layers) for p in _STATE["pads"]],
            "zones": zone_records(board, layers), "graphics": graphic_records(board, layers),
            "net_count": int(board.GetNetCount()),
            "edge_clearance": int(settings.m_CopperEdgeClearance),
            "hole_clearance": int(settings.m_HoleClearance),
            "clearance": int(settings.m_MinClearance)}


def snapshot(drc: bool = False) -> dict:
    """The routing state: copper (tracks, vias with cluster labels), per-pad cluster labels, the
    evaluator's measurements (clusters per net, WL, vias, net count), KiCad's unconnected count
    and, with `drc`, KiCad's DRC violations."""
    board = _board()
    tracks, pads = list(board.GetTracks()), _STATE["pads"]
    # One clustering gives the env's labels and the evaluator's per-net counts (`pad_clusters`
    # is the same function over the same items), so finish targets and U agree with `eval`.
    items = pads + tracks + list(board.Zones())
    ids, nets = item_keys(items)
    labels = copper_labels(board, items, _STATE["links"], (ids, nets))
    npads = len(pads)
    span = slice(npads, npads + len(tracks))
    copper = _records(tracks, ids[span], nets[span])
    for i, record in enumerate(copper):
        record["cluster"] = labels[npads + i]
    wl_mm, vias = totals_of((r["kind"], r.get("start"), r.get("end"), r.get("mid"))
                            for r in copper)
    return {"copper": copper,
            "pad_cluster": labels[:npads], "clusters": clusters_per_net(pads, labels[:npads]),
            "wl_mm": wl_mm,
            "vias": vias, "net_count": int(board.GetNetCount()),
            "unconnected": int(board.GetConnectivity().GetUnconnectedCount(False)),
            "violations": _violations(board) if drc else None}


def _records(tracks: list, ids: list[str], nets: list[int]) -> list[dict]:
    """`track_record` of each track (cluster 0: the caller sets it), new dicts every call;
    a track's record is remembered by its KiCad id and net (`ids`, `nets`), since the worker
    never moves an item (edits add and delete), unless the ids are not distinct."""
    names = {lid: name for name, lid in _STATE["layers"].items()}
    memory: dict = _STATE["records"] if len(set(ids)) == len(ids) else {}
    out = []
    for uid, net, track in zip(ids, nets, tracks):
        known = memory.get(uid)
        if known is None or known[0] != net:
            known = memory[uid] = (net, track_record(track, names, 0))
        out.append(dict(known[1]))
    return out


def _violations(board) -> list[dict]:
    """KiCad's DRC of the edited board: its step DRC plus the instance's static violations,
    without the warnings no counting counts."""
    return _counted_ones(located_violations(board) + _STATE["static_violations"])


def _counted_ones(violations: list[dict]) -> list[dict]:
    counted = _STATE["counted_warnings"]
    return [v for v in violations if not is_uncounted_warning(v, counted)]


def _add_track(board, net, layer: int, points: list, width: int) -> None:
    pcbnew = _pcbnew()
    for (x1, y1), (x2, y2) in zip(points, points[1:]):
        if (x1, y1) == (x2, y2):
            continue
        track = pcbnew.PCB_TRACK(board)
        track.SetStart(pcbnew.VECTOR2I(int(x1), int(y1)))
        track.SetEnd(pcbnew.VECTOR2I(int(x2), int(y2)))
        track.SetWidth(int(width))
        track.SetLayer(layer)
        track.SetNet(net)
        board.Add(track)


def _add_via(board, net, at: tuple, diameter: int, drill: int, top: int, bottom: int) -> None:
    pcbnew = _pcbnew()
    via = pcbnew.PCB_VIA(board)
    via.SetViaType(pcbnew.VIATYPE_THROUGH)
    via.SetPosition(pcbnew.VECTOR2I(int(at[0]), int(at[1])))
    via.SetLayerPair(top, bottom)
    via.SetWidth(int(diameter))
    via.SetDrill(int(drill))
    via.SetNet(net)
    board.Add(via)


def _matching(board, edit: dict, layers: dict[str, int]) -> list:
    """The items a removal names: straight tracks of that net, layer, ends (either way round)
    and width ({"kind": "remove"}), or vias of that net at that point ({"kind": "remove_via"})."""
    pcbnew = _pcbnew()
    out = []
    for item in board.GetTracks():
        if str(item.GetNetname()) != edit["net"]:
            continue
        if edit["kind"] == "remove_via":
            if item.Type() == pcbnew.PCB_VIA_T and _xy(item.GetPosition()) == tuple(edit["at"]):
                out.append(item)
        elif item.Type() == pcbnew.PCB_TRACE_T and item.GetLayer() == layers[edit["layer"]] \
                and int(item.GetWidth()) == edit["width"] \
                and {_xy(item.GetStart()), _xy(item.GetEnd())} == {tuple(edit["start"]),
                                                                   tuple(edit["end"])}:
            out.append(item)
    return out


def _xy(point) -> tuple[int, int]:
    return int(point.x), int(point.y)


def _remove(board, edit: dict, layers: dict[str, int]) -> None:
    found = _matching(board, edit, layers)
    if not found:
        what = "via" if edit["kind"] == "remove_via" else "track"
        raise ValueError(f"no {what} of net {edit['net']!r} to remove at "
                         f"{edit.get('at') or (edit['start'], edit['end'])}")
    # One item per edit: the router's board may hold two identical tracks (a line drawn twice),
    # and a plan that takes both up sends two edits.
    board.Delete(found[0])  # never Remove: it leaves the item half-owned and damages pcbnew


def apply(edits: list[dict], drc: bool = False) -> dict:
    """Adds tracks ({"kind": "track", net, layer, points, width}) and through vias
    ({"kind": "via", net, at, diameter, drill}) as KiCad items and deletes the tracks and vias
    that removals name ({"kind": "remove", net, layer, start, end, width};
    {"kind": "remove_via", net, at}), in order; returns `snapshot(drc)`."""
    board = _board()
    layers = _STATE["layers"]
    nets = board.GetNetsByName()
    _pcbnew().KIID.SeedGenerator(UUID_SEED + _STATE["applies"])
    _STATE["applies"] += 1
    for edit in edits:
        if edit["kind"] in ("remove", "remove_via"):
            _remove(board, edit, layers)
            continue
        net = nets[edit["net"]]
        if edit["kind"] == "track":
            _add_track(board, net, layers[edit["layer"]], edit["points"], edit["width"])
        else:
            ids = list(layers.values())
            _add_via(board, net, edit["at"], edit["diameter"], edit["drill"], ids[0], ids[-1])
    # The board keeps its connectivity's items as they are added and deleted; the ratsnest's
    # recalculation searches the new links (and propagates nets), the same answers as
    # rebuilding it all (tests/env/test_clusters.py) at a fraction of the time on a large board.
    board.GetConnectivity().RecalculateRatsnest()
    return snapshot(drc)


def _removal(item, names: dict[int, str]) -> dict:
    """The removal edit of one KiCad track or via (with what `undo` needs to add it again)."""
    pcbnew = _pcbnew()
    net = str(item.GetNetname())
    if item.Type() == pcbnew.PCB_VIA_T:
        return {"kind": "remove_via", "net": net, "at": _xy(item.GetPosition()),
                "diameter": int(item.GetWidth(item.TopLayer())),
                "drill": int(item.GetDrillValue())}
    return {"kind": "remove", "net": net, "layer": names[int(item.GetLayer())],
            "start": _xy(item.GetStart()), "end": _xy(item.GetEnd()),
            "width": int(item.GetWidth())}


def prune(nets: list[str], drc: bool = False) -> dict:
    """Deletes the tracks and vias of `nets` that KiCad's connectivity finds dangling (an end
    or a via joined to nothing), again until none is left: the stubs and lone vias a route
    that went nowhere leaves. A dangling track whose body still crosses copper of its net (a
    reroute's crossing) is shortened to that crossing instead, once. Returns {"edits": the
    removals and shortened tracks, in order, "snapshot": `snapshot(drc)`, or None when nothing
    changed}."""
    board = _board()
    pcbnew = _pcbnew()
    names = {lid: name for name, lid in _STATE["layers"].items()}
    wanted, edits, shortened = set(nets), [], set()
    kinds = (pcbnew.PCB_TRACE_T, pcbnew.PCB_VIA_T)
    while True:
        connectivity = board.GetConnectivity()
        gone = [t for t in board.GetTracks() if t.Type() in kinds
                and str(t.GetNetname()) in wanted
                and connectivity.TestTrackEndpointDangling(t, False)]
        if not gone:
            break
        for item in gone:
            cut = None
            if item.Type() == pcbnew.PCB_TRACE_T and _ends(item) not in shortened:
                cut = stub_cut(_ends(item), _net_copper(board, item))
            edits.append(_removal(item, names))
            board.Delete(item)
            if cut is not None:
                edits.append(_shorten(board, edits[-1], cut))
                shortened.add((tuple(cut[0]), tuple(cut[1])))
        board.BuildConnectivity()
    return {"edits": edits, "snapshot": snapshot(drc) if edits else None}


def _ends(track) -> tuple[tuple[int, int], tuple[int, int]]:
    return _xy(track.GetStart()), _xy(track.GetEnd())


def _shorten(board, removal: dict, cut: tuple) -> dict:
    """Adds the kept part of a removed track (`removal`); returns its edit."""
    pcbnew = _pcbnew()
    pcbnew.KIID.SeedGenerator(UUID_SEED + _STATE["applies"])  # a new item: seeded, as `apply`
    _STATE["applies"] += 1
    edit = {"kind": "track", "net": removal["net"], "layer": removal["layer"],
            "points": [cut[0], cut[1]], "width": removal["width"]}
    _add_track(board, board.GetNetsByName()[edit["net"]], _STATE["layers"][edit["layer"]],
               edit["points"], edit["width"])
    return edit


def _net_copper(board, track) -> dict:
    """The copper of a track's net on its layer, without the track, as
    `copper_geometry.stub_cut` takes it: tracks, vias, pads (nm)."""
    pcbnew = _pcbnew()
    layer, net, own = track.GetLayer(), track.GetNetCode(), track.m_Uuid.AsString()
    copper: dict = {"segments": [], "circles": [], "polygons": []}
    for item in board.GetTracks():
        if item.GetNetCode() != net or item.m_Uuid.AsString() == own:
            continue
        if item.Type() == pcbnew.PCB_VIA_T:
            copper["circles"].append((_xy(item.GetPosition()), item.GetWidth(layer) / 2))
        elif item.Type() == pcbnew.PCB_TRACE_T and item.GetLayer() == layer:
            copper["segments"].append((*_ends(item), item.GetWidth() / 2))
    for pad in _STATE["pads"]:
        if pad.GetNetCode() == net and pad.IsOnLayer(layer):
            copper["polygons"] += polygon_rings(pad.GetEffectivePolygon(layer,
                                                                        pcbnew.ERROR_INSIDE))
    return copper


def copper_edits(path: str, stage_dir: str) -> list[dict]:
    """The straight tracks and vias of the board at `path` (a routed board, read from a copy
    in `stage_dir`: KiCad writes lock files beside what it loads) as `apply` edits, in the
    board's order: laying a routing again on its instance, for tests and benchmarks."""
    pcbnew = _pcbnew()
    loaded = _load(shutil.copy(path, os.path.join(_new_folder(stage_dir), BOARD_FILE)), path)
    edits = []
    for item in loaded.GetTracks():
        net = str(item.GetNetname())
        if item.Type() == pcbnew.PCB_VIA_T:
            edits.append({"kind": "via", "net": net, "at": _xy(item.GetPosition()),
                          "diameter": int(item.GetWidth(item.TopLayer())),
                          "drill": int(item.GetDrillValue())})
        elif item.Type() == pcbnew.PCB_TRACE_T:
            edits.append({"kind": "track", "net": net, "width": int(item.GetWidth()),
                          "layer": str(loaded.GetLayerName(item.GetLayer())),
                          "points": [_xy(item.GetStart()), _xy(item.GetEnd())]})
    return edits


def save(path: str) -> str:
    """Writes the board (the instance's own board plus the added copper) as a `.kicad_pcb`;
    the project is not written (the evaluator uses the instance's own)."""
    pcbnew = _pcbnew()
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    if not pcbnew.SaveBoard(path, _board(), True):
        raise RuntimeError(f"{path}: KiCad could not save the board")
    return path


def close() -> None:
    """Forgets the board (the worker stays up for the next instance)."""
    _STATE.clear()

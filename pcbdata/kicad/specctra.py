"""Specctra round trip through KiCad: export DSN, run a router, import SES, save the board.

Runs inside engine worker processes only. The router is any command that reads a DSN file and
writes an SES file; `{dsn}` and `{ses}` in its argument list are replaced by the file paths.
"""
from __future__ import annotations

import os
import re
import subprocess
import tempfile
import time

from pcbdata.core.sexpr_text import block_end
from pcbdata.kicad.basics import pcbnew_module as _pcbnew
from pcbdata.kicad.scoring import stage_board

_RESOLUTION = re.compile(rb"\(resolution\s+(\w+)\s+(\d+)\)")
_DSN_UNIT = re.compile(rb"\(unit\s+(\w+)\)")


def fix_ses_resolution(dsn: bytes, ses: bytes) -> bytes:
    """Makes the SES resolution match the unit the coordinates are written in.

    freeroute 2026.7.14 writes SES coordinates in the DSN's unit (um for KiCad's export) but
    labels them with the DSN's resolution (`(resolution um 10)`), so KiCad would import every
    track 10x too small. Rewrites `(resolution U N)` to `(resolution U 1)` when the DSN declares
    `(unit U)`; a correct SES (coordinates in resolution units) is not touched because its
    coordinates would then be N times larger than the DSN's, which this check detects.
    """
    if _DSN_UNIT.search(dsn) is None:
        return ses
    place = re.compile(rb"\(place\s+(\S+)\s+(-?[\d.]+)\s+(-?[\d.]+)")
    dsn_x = {m.group(1): float(m.group(2)) for m in place.finditer(dsn)}
    for m in place.finditer(ses):
        x_dsn = dsn_x.get(m.group(1))
        if x_dsn is not None and abs(x_dsn) > 1:
            if abs(float(m.group(2)) / x_dsn - 1) > 0.01:
                return ses  # SES coordinates are scaled: they already follow its resolution
            break
    return _RESOLUTION.sub(lambda m: b"(resolution " + m.group(1) + b" 1)", ses)


def strip_ses_placement(ses: str) -> str:
    """Removes the `(placement ...)` section of an SES session: routers echo the components'
    placement (freeroute rounds it to 1 um), and KiCad's import would move footprints to it -
    which the evaluator's integrity check rightly rejects. Routing never moves components."""
    match = re.search(r"\(placement\s", ses)
    if match is None:
        return ses
    try:
        return ses[:match.start()] + ses[block_end(ses, match.start()):]
    except ValueError:  # a truncated session: KiCad's import will report it
        return ses


def route_board(board_path: str, instance_dir: str, out_path: str, command: list[str],
                router_timeout: float, fix_resolution: bool = False,
                flip_back: bool = False, plan_for_vias: bool = False,
                exact_pads: bool = False) -> dict:
    """Exports the board as DSN, runs `command` on it, imports the SES and saves the routed
    board to `out_path`. `fix_resolution`, `flip_back`, `plan_for_vias` and `exact_pads` work
    around freeroute defects (see `fix_ses_resolution`, `pcbdata.kicad.specctra_text` and
    `pcbdata.kicad.specctra_pads`).
    Returns {ok, reason, seconds, router_seconds, router_cpu_seconds, tracks, vias}."""
    pcbnew = _pcbnew()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="pcbdata-route-") as tmp:
        staged = stage_board(board_path, instance_dir, tmp)
        board = pcbnew.LoadBoard(staged)
        dsn, ses = os.path.join(tmp, "board.dsn"), os.path.join(tmp, "board.ses")
        if not pcbnew.ExportSpecctraDSN(board, dsn):
            return {"ok": False, "reason": "KiCad could not export the DSN file"}
        with open(dsn, encoding="utf-8") as handle:
            text, back_refs, planning = router_dsn(handle.read(), flip_back, plan_for_vias,
                                                   exact_pads)
        with open(dsn, "w", encoding="utf-8") as handle:
            handle.write(text)
        argv = [a.replace("{dsn}", dsn).replace("{ses}", ses) for a in command]
        router_start, cpu_start = time.perf_counter(), _children_cpu()
        try:
            result = subprocess.run(argv, capture_output=True, timeout=router_timeout, cwd=tmp,
                                    preexec_fn=_die_with_parent)
        except subprocess.TimeoutExpired:
            return {"ok": False, "reason": f"router exceeded {router_timeout:g} s",
                    "seconds": time.perf_counter() - start, "router_seconds": router_timeout}
        except OSError as exc:
            return {"ok": False, "reason": f"router could not start: {exc}"}
        router_seconds = time.perf_counter() - router_start
        router_cpu = _children_cpu() - cpu_start
        if result.returncode != 0 or not os.path.isfile(ses) or os.path.getsize(ses) == 0:
            tail = result.stderr.decode(errors="replace").strip().splitlines()[-1:] or [""]
            reason = f"router failed (exit {result.returncode}) {tail[0]}".strip()
            return {"ok": False, "reason": reason,
                    "seconds": time.perf_counter() - start, "router_seconds": router_seconds}
        if fix_resolution:
            with open(dsn, "rb") as handle:
                dsn_bytes = handle.read()
            with open(ses, "rb") as handle:
                fixed = fix_ses_resolution(dsn_bytes, handle.read())
            with open(ses, "wb") as handle:
                handle.write(fixed)
        if back_refs:
            from pcbdata.kicad.specctra_text import restore_back_placements

            with open(ses, encoding="utf-8") as handle:
                text = restore_back_placements(handle.read(), back_refs)
            with open(ses, "w", encoding="utf-8") as handle:
                handle.write(text)
        with open(ses, encoding="utf-8", errors="replace") as handle:
            text = strip_ses_placement(handle.read())
        if planning:
            from pcbdata.kicad.specctra_text import restore_ses_after_freeroute

            text = restore_ses_after_freeroute(text, planning)
        with open(ses, "w", encoding="utf-8") as handle:
            handle.write(text)
        if not pcbnew.ImportSpecctraSES(board, ses):
            return {"ok": False, "reason": "KiCad could not import the SES file"}
        tracks = vias = 0
        for item in board.GetTracks():
            if item.Type() == pcbnew.PCB_VIA_T:
                vias += 1
            else:
                tracks += 1
        saved = os.path.join(tmp, "routed.kicad_pcb")
        board.Save(saved)
        os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
        os.replace(saved, out_path) if _same_fs(saved, out_path) else _copy(saved, out_path)
        return {"ok": True, "reason": "", "seconds": time.perf_counter() - start,
                "router_seconds": router_seconds, "router_cpu_seconds": router_cpu,
                "tracks": tracks, "vias": vias}


def router_dsn(text: str, flip_back: bool, plan_for_vias: bool,
               exact_pads: bool) -> tuple[str, set[str], dict]:
    """KiCad's DSN with the chosen freeroute work-arounds: (text, references flipped from the
    back, what the session needs back after planning for vias). The pads are rewritten last:
    mirrored images turn their pins the other way."""
    from pcbdata.kicad.specctra_pads import exact_pads as rewrite_pads
    from pcbdata.kicad.specctra_text import flip_back_components, prepare_dsn_for_freeroute

    planning: dict = {}
    back_refs: set[str] = set()
    if plan_for_vias:
        text, planning = prepare_dsn_for_freeroute(text)
    if flip_back:
        text, back_refs = flip_back_components(text)
    if exact_pads:
        text = rewrite_pads(text)
    return text, back_refs, planning


def dsn_and_pads(board_path: str, instance_dir: str, fixes: bool = True) -> dict:
    """The DSN a router is given for this board (with every freeroute work-around when
    `fixes`) and KiCad's pads as boxes in the DSN's frame (micrometres, y up):
    {"dsn": text, "pads": [{"name", "layers", "through_hole", "box": (x1, y1, x2, y2)}]}.
    What the router reads can then be checked against the board."""
    pcbnew = _pcbnew()
    with tempfile.TemporaryDirectory(prefix="pcbdata-dsn-") as tmp:
        board = pcbnew.LoadBoard(stage_board(board_path, instance_dir, tmp))
        dsn = os.path.join(tmp, "board.dsn")
        if not pcbnew.ExportSpecctraDSN(board, dsn):
            raise RuntimeError(f"{board_path}: KiCad could not export the DSN file")
        with open(dsn, encoding="utf-8") as handle:
            text = router_dsn(handle.read(), fixes, fixes, fixes)[0]
    pads = []
    for pad in board.GetPads():
        for layer in board.GetEnabledLayers().CuStack():
            if not pad.IsOnLayer(layer):
                continue
            box = pad.GetEffectivePolygon(layer, pcbnew.ERROR_INSIDE).BBox()
            x1, y1 = box.GetX(), box.GetY()
            x2, y2 = x1 + box.GetWidth(), y1 + box.GetHeight()
            pads.append({"name": f"{pad.GetParentFootprint().GetReference()}:{pad.GetNumber()}",
                         "layer": str(board.GetLayerName(layer)),
                         "through_hole": pad.GetDrillSize().x > 0,
                         "box": (x1 / 1000, -y2 / 1000, x2 / 1000, -y1 / 1000)})
    return {"dsn": text, "pads": pads}


def _children_cpu() -> float:
    """CPU seconds used so far by this worker's finished child processes (the router)."""
    times = os.times()
    return times.children_user + times.children_system


def _die_with_parent() -> None:
    """In the router's process: ask Linux to kill it if the engine worker dies (time limit)."""
    try:
        import ctypes
        import signal

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _same_fs(a: str, b: str) -> bool:
    try:
        return os.stat(a).st_dev == os.stat(os.path.dirname(os.path.abspath(b))).st_dev
    except OSError:
        return False


def _copy(source: str, target: str) -> None:
    import shutil

    partial = target + ".partial"
    shutil.copyfile(source, partial)
    os.replace(partial, target)

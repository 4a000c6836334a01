"""The second baseline router: kicad-tools' `kct route` (MIT, optional extra `kicad-tools`).

It reads and writes `.kicad_pcb` directly, so there is no Specctra round trip. It only ever
runs as a separate process. Three things need care, all handled here:
- it classifies nets by name (power, high-speed, ...) and then ignores both the board's net
  class and its own width flags for them: we give it a net-class map made from the instance's
  `board.kicad_pro`, one entry per net, so every net routes with the instance's rules;
- it adds copper layers unless told `--layers 2 --no-auto-layers` (the integrity check would
  reject a board with more layers);
- it writes its own rule files beside its output: they are left in a private folder and never
  used for scoring (the evaluator only ever uses the instance's project).
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

from pcbdata.core.errors import UserError
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE

EXECUTABLE = "kct"
#: `--seed` per rollout: the router is deterministic for a given seed.
SEEDS = (0, 1, 2, 3, 4)
_NET = re.compile(r'^\s*\(net\s+\d+\s+"((?:[^"\\]|\\.)*)"\)', re.M)


def executable() -> str | None:
    """`kct` next to this interpreter (a venv) or on PATH; None when not installed."""
    local = os.path.join(os.path.dirname(sys.executable), EXECUTABLE)
    if os.access(local, os.X_OK):
        return local
    return shutil.which(EXECUTABLE)


def version() -> str:
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("kicad-tools")
    except PackageNotFoundError:
        return "unknown"


def default_rules(project_path: str) -> dict:
    """Track width, clearance, via and edge clearance (mm) of the instance's Default class."""
    with open(project_path, encoding="utf-8") as handle:
        project = json.load(handle)
    classes = project.get("net_settings", {}).get("classes", [])
    fallback = classes[0] if classes else {}
    default = next((c for c in classes if c.get("name") == "Default"), fallback)
    rules = project.get("board", {}).get("design_settings", {}).get("rules", {})
    return {"track_width": float(default.get("track_width", 0.2)),
            "clearance": float(default.get("clearance", 0.2)),
            "via_diameter": float(default.get("via_diameter", 0.6)),
            "via_drill": float(default.get("via_drill", 0.3)),
            "edge_clearance": float(rules.get("min_copper_edge_clearance", 0.0))}


def net_class_map(board_text: str, rules: dict) -> dict:
    """One entry per net of the board, all with the instance's Default rules, so that no net
    is re-classified by its name."""
    nets = sorted({name for name in _NET.findall(board_text) if name})
    entry = {"name": "Default", "trace_width": rules["track_width"],
             "clearance": rules["clearance"], "via_size": rules["via_diameter"]}
    return {"_comment": "pcbdata: every net routes with the instance's Default net class",
            **{net: dict(entry) for net in nets}}


def command(board: str, out: str, rules: dict, class_map: str, seed: int,
            timeout: float) -> list[str]:
    exe = executable()
    if exe is None:
        raise UserError("kicad-tools is not installed; run: pip install 'pcbdata[kicad-tools]'")
    return [exe, "route", board, "-o", out, "--layers", "2", "--no-auto-layers",
            "--trace-width", f"{rules['track_width']:g}", "--clearance", f"{rules['clearance']:g}",
            "--via-diameter", f"{rules['via_diameter']:g}",
            "--via-drill", f"{rules['via_drill']:g}",
            "--edge-clearance", f"{rules['edge_clearance']:g}", "--net-class-map", class_map,
            "--seed", str(seed), "--timeout", f"{timeout:g}", "--quiet"]


def route_board(board_path: str, instance_dir: str, out_path: str, seed: int,
                router_timeout: float) -> dict:
    """Routes one instance with `kct route` in a private folder; copies the routed board to
    `out_path`. Returns {ok, reason, seconds, router_seconds, router_cpu_seconds}."""
    start = time.perf_counter()
    rules = default_rules(os.path.join(instance_dir, PROJECT_FILE))
    with tempfile.TemporaryDirectory(prefix="pcbdata-kct-") as tmp:
        board = os.path.join(tmp, BOARD_FILE)
        shutil.copyfile(board_path, board)
        class_map = os.path.join(tmp, "net_classes.json")
        with open(board, encoding="utf-8") as handle:
            classes = net_class_map(handle.read(), rules)
        with open(class_map, "w", encoding="utf-8") as handle:
            json.dump(classes, handle, indent=1, sort_keys=True)
        routed = os.path.join(tmp, "routed.kicad_pcb")
        argv = command(board, routed, rules, class_map, seed, router_timeout)
        result, cpu = _run(argv, tmp, router_timeout + 30)
        seconds = time.perf_counter() - start
        if result is None:
            return {"ok": False, "reason": f"router exceeded {router_timeout:g} s",
                    "seconds": seconds, "router_seconds": seconds, "router_cpu_seconds": cpu}
        if not os.path.isfile(routed) or os.path.getsize(routed) == 0:
            tail = result.stderr.decode(errors="replace").strip().splitlines()[-1:] or [""]
            reason = f"router failed (exit {result.returncode}) {tail[0]}".strip()
            return {"ok": False, "reason": reason,
                    "seconds": seconds, "router_seconds": seconds, "router_cpu_seconds": cpu}
        os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
        partial = out_path + ".partial"
        shutil.copyfile(routed, partial)
        os.replace(partial, out_path)
    return {"ok": True, "reason": "", "seconds": time.perf_counter() - start,
            "router_seconds": time.perf_counter() - start, "router_cpu_seconds": cpu,
            "exit_code": result.returncode}


def _run(argv: list[str], cwd: str, timeout: float):
    """(CompletedProcess or None on time-out, CPU seconds of the router's process tree)."""
    before = os.times()
    try:
        result = subprocess.run(argv, capture_output=True, timeout=timeout, cwd=cwd)
    except subprocess.TimeoutExpired:
        result = None
    after = os.times()
    cpu = ((after.children_user - before.children_user)
           + (after.children_system - before.children_system))
    return result, cpu

"""Board previews for the dataset card: `kicad-cli pcb export svg`, run inside `KicadPool`
workers (`pcbdata.publish.pictures.PreviewRenderer` maps `render_svg` over the boards)."""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile

from pcbdata.kicad.cli_tools import kicad_cli
from pcbdata.tree import BOARD_FILE, PROJECT_FILE

LAYERS = "F.Cu,B.Cu,Edge.Cuts"


def render_svg(board_path: str, project_path: str | None, timeout: float = 120) -> dict:
    """The board's copper and outline as SVG text: {"svg": text} or {"reason": why not}.

    KiCad works on copies in a temporary folder, so it never touches the published tree.
    Previews are illustrations, never required: a failure is a reason, not an exception."""
    try:
        cli = kicad_cli()
    except FileNotFoundError as exc:
        return {"reason": str(exc)}
    with tempfile.TemporaryDirectory(prefix="pcbdata-preview-") as tmp:
        board = os.path.join(tmp, BOARD_FILE)
        shutil.copyfile(board_path, board)
        if project_path is not None and os.path.isfile(project_path):
            shutil.copyfile(project_path, os.path.join(tmp, PROJECT_FILE))
        svg = os.path.join(tmp, "preview.svg")
        try:
            subprocess.run([cli, "pcb", "export", "svg", "--layers", LAYERS,
                            "--mode-single", "--exclude-drawing-sheet", "--page-size-mode", "2",
                            "--output", svg, board],
                           check=True, capture_output=True, timeout=timeout)
        except (subprocess.CalledProcessError, subprocess.TimeoutExpired, OSError) as exc:
            return {"reason": f"kicad-cli failed: {exc}"}
        if not os.path.isfile(svg):
            return {"reason": "kicad-cli wrote no SVG"}
        with open(svg, encoding="utf-8") as handle:
            return {"svg": handle.read()}

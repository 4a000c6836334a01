"""`pcbdata render`: PNG pictures of boards (copper per layer, pads, vias, ratsnest)."""
from __future__ import annotations

import argparse
import os
import sys

from pcbdata.cli import _checks as checks

VERB = "render"
HELP = "draw boards as PNG: a .kicad_pcb, a folder of boards, or RUNS (with --report: the best " \
       "rollout of each board next to the reference)"


def register(parser) -> None:
    parser.add_argument("target", metavar="BOARD_OR_RUNS",
                        help="a .kicad_pcb, a folder of boards (any depth), or a RUNS folder")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="picture folder: DIR/<path of the board under the folder>.png "
                             "(with --report: DIR/<board_id>.png)")
    parser.add_argument("--report", metavar="REPORT",
                        help="a `pcbdata eval` report of RUNS: draw each board's best rollout")
    parser.add_argument("--set", metavar="SET", dest="set_root",
                        help="with --report: the built set, to draw each instance's reference "
                             "routing next to the best rollout (needs --config)")
    parser.add_argument("--config", help="with --set: config name, e.g. d2, d3-a")
    parser.add_argument("--split", default="test", help="with --set: split (default: test)")
    parser.add_argument("--workers", type=checks.workers, default=os.cpu_count() or 1,
                        help="KiCad worker processes reading boards (default: cores)")
    parser.add_argument("--drc", action="store_true",
                        help="mark KiCad's DRC errors (rules: the instance's with --set, else "
                             "the .kicad_pro beside the board, else KiCad's defaults)")
    parser.add_argument("--size", type=panel_size, default=(640, 480), metavar="WxH",
                        help="pixels of one board panel (default: 640x480)")
    parser.add_argument("--timeout", type=checks.seconds, default=120.0,
                        help="seconds allowed per board (default: 120)")
    parser.set_defaults(run=run)


def panel_size(text: str) -> tuple[int, int]:
    """WxH, each from 32 to 8192 pixels."""
    width, _, height = text.lower().partition("x")
    if not (width.isdigit() and height.isdigit() and 32 <= int(width) <= 8192
            and 32 <= int(height) <= 8192):
        raise argparse.ArgumentTypeError(f"must be WxH with each from 32 to 8192, got {text!r}")
    return int(width), int(height)


def run(args) -> int:
    from pcbdata.board_render import instance_folder, render_boards
    from pcbdata.core.errors import UserError

    if args.set_root and not args.report:
        raise UserError("--set needs --report (the reference is drawn next to the best rollout)")
    if args.set_root and not args.config:
        raise UserError("--set needs --config (which config of the set holds the boards)")
    instances = instance_folder(args.set_root, args.config, args.split) \
        if args.set_root else None
    summary = render_boards(args.target, args.out, report=args.report, instances=instances,
                            workers=args.workers, timeout=args.timeout, size=args.size,
                            drc=args.drc)
    print(f"done: {summary['written']} pictures in {args.out}, {len(summary['failed'])} not "
          f"drawn, {summary['seconds']:.1f} s")
    if summary["failed"]:
        print(f"pcbdata: {len(summary['failed'])} boards could not be drawn (see above)",
              file=sys.stderr)
        return 3
    return 0

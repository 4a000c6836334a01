"""A small PCBench-shaped corpus made from generated boards, one board per fate.

Layout as in a PCBench checkout: `PCBs/<name>/processed.kicad_pcb` (here KiCad 9 text; KiCad
loads it like the legacy files), `final.json`, `metadata.json`; `github_meta/github_1.json`;
`LICENSE`.
"""
from __future__ import annotations

import json
from pathlib import Path

from pcbdata.model.board import Board, Pad, Rules, Track, mm_to_nm
from pcbdata.model.kicad_writer import board_text

RULES = Rules(clearance=mm_to_nm(0.2), track_width=mm_to_nm(0.25),
              edge_clearance=mm_to_nm(0.3), via_diameter=mm_to_nm(0.8),
              via_drill=mm_to_nm(0.4))
MIT = {"key": "mit", "name": "MIT License", "spdx_id": "MIT",
       "url": "https://api.github.com/licenses/mit", "node_id": "x"}


def row_board(nets: int, seed: str, routed: bool = True, unrouted_nets: int = 0,
              short: bool = False) -> Board:
    """`nets` two-pad nets, pads 20 mm apart in rows 5 mm apart, each joined by one track.

    `unrouted_nets`: the last ones get no track (not fully connected). `short`: one extra
    track of net 1 runs across every other net's track (DRC errors).
    """
    pads, tracks = [], []
    height = 10 + 5 * nets
    size = mm_to_nm(1.0)
    for k in range(nets):
        y = mm_to_nm(7.5 + 5 * k)
        net = f"N{k + 1}"
        a = Pad(x=mm_to_nm(10), y=y, net=net, kind="smd_rect", size=size)
        b = Pad(x=mm_to_nm(30), y=y, net=net, kind="smd_rect", size=size)
        pads += [a, b]
        if routed and k < nets - unrouted_nets:
            tracks.append(Track(a.x, a.y, b.x, b.y, RULES.track_width, net))
    if short and nets >= 2:
        tracks.append(Track(mm_to_nm(20), mm_to_nm(7.5), mm_to_nm(20),
                            mm_to_nm(7.5 + 5 * (nets - 1)), RULES.track_width, "N1"))
    return Board(width=mm_to_nm(40), height=mm_to_nm(height), rules=RULES, pads=pads,
                 tracks=tracks, uuid_seed=seed)


def legacy_board_text(nets: int = 2, pitch: float = 1.5, clearance: float = 0) -> str:
    """A KiCad 5 (version 20171130) board with `nets` routed two-pad nets `pitch` mm apart and
    a Default netclass clearance of `clearance` (0: the board stores no usable clearance, so
    the compatibility pass measures the spacing: pads 1 mm, so pitch - 1 mm)."""
    out = ['(kicad_pcb (version 20171130) (host pcbnew "(5.1.12)")',
           "  (general (thickness 1.6))", "  (page A4)",
           "  (layers (0 F.Cu signal) (31 B.Cu signal) (44 Edge.Cuts user))",
           f"  (setup (last_trace_width 0.25) (trace_clearance {clearance}) (zone_clearance 0.508)"
           " (zone_45_only no) (trace_min 0.2) (via_size 0.8) (via_drill 0.4) (via_min_size 0.4)"
           " (via_min_drill 0.3) (uvia_size 0.3) (uvia_drill 0.1) (uvias_allowed no)"
           " (uvia_min_size 0.2) (uvia_min_drill 0.1) (edge_width 0.05) (segment_width 0.2)"
           " (pcb_text_width 0.3) (pcb_text_size 1.5 1.5) (mod_edge_width 0.12)"
           " (mod_text_size 1 1) (mod_text_width 0.15) (pad_size 1.524 1.524)"
           " (pad_drill 0.762) (pad_to_mask_clearance 0.051) (aux_axis_origin 0 0)"
           " (visible_elements FFFFFF7F))",
           '  (net 0 "")']
    out += [f"  (net {k} N{k})" for k in range(1, nets + 1)]
    out.append(f'  (net_class Default "default" (clearance {clearance}) (trace_width 0.25)'
               " (via_dia 0.8) (via_drill 0.4) (uvia_dia 0.3) (uvia_drill 0.1) "
               + " ".join(f"(add_net N{k})" for k in range(1, nets + 1)) + ")")
    font = "(effects (font (size 1 1) (thickness 0.15)))"
    for k in range(1, nets + 1):
        y = 5 + pitch * k
        for j, x in enumerate((10, 30)):
            out.append(f"  (module P{k}_{j} (layer F.Cu) (tedit 0) (tstamp 0) (at {x} {y})"
                       f" (fp_text reference P{k}_{j} (at 0 0) (layer F.Fab) hide {font})"
                       f" (fp_text value V (at 0 0) (layer F.Fab) hide {font})"
                       f" (pad 1 smd rect (at 0 0) (size 1 1) (layers F.Cu) (net {k} N{k})))")
        out.append(f"  (segment (start 10 {y}) (end 30 {y}) (width 0.25) (layer F.Cu)"
                   f" (net {k}))")
    h = 10 + pitch * nets
    for (x1, y1), (x2, y2) in (((0, 0), (40, 0)), ((40, 0), (40, h)), ((40, h), (0, h)),
                               ((0, h), (0, 0))):
        out.append(f"  (gr_line (start {x1} {y1}) (end {x2} {y2}) (layer Edge.Cuts)"
                   " (width 0.05))")
    return "\n".join(out) + "\n)\n"


def legacy_final_json(nets: int = 2, pitch: float = 1.5) -> dict:
    pads = {str(k): [{"type": "smd", "layer": ["F.Cu"], "shape": "rect",
                      "center": [x, 5 + pitch * k], "radii": [0.5, 0.5], "rotation": 0}
                     for x in (10, 30)] for k in range(1, nets + 1)}
    return {"layers": ["F.Cu", "B.Cu"], "unit": "mm", "nets": pads}


def final_json(board: Board) -> dict:
    nets: dict[str, list] = {}
    for number, name in enumerate(board.net_names, start=1):
        nets[str(number)] = [
            {"type": "smd", "layer": ["F.Cu"], "shape": "rect",
             "center": [p.x / 1e6, p.y / 1e6], "radii": [0.5, 0.5], "rotation": 0}
            for p in board.pads if p.net == name]
    return {"layers": ["F.Cu", "B.Cu"], "unit": "mm", "border": [], "nets": nets,
            "differential_pairs": [], "keepouts": [], "rules": {}, "solution": {}}


def _folder(root: Path, name: str, board_bytes: bytes | None, final: dict | bytes | None,
            repo: str, licences=None) -> Path:
    folder = root / "PCBs" / name
    folder.mkdir(parents=True)
    if board_bytes is not None:
        (folder / "processed.kicad_pcb").write_bytes(board_bytes)
    if final is not None:
        (folder / "final.json").write_bytes(
            final if isinstance(final, bytes) else json.dumps(final).encode())
    meta = {"org": repo.rsplit("/", 1)[0], "source": repo, "author": "",
            "licenses": licences, "layers": 2, "CAD version": "KiCad 9"}
    (folder / "metadata.json").write_text(json.dumps(meta))
    return folder


# name -> expected fate of the fixture corpus
KEPT_NAMES = {
    # name: number of nets (pads = 2 * nets)
    "alpha": 1,
    "bravo board": 2,
    "charlie (rev 2)": 3,
    "delta 'quoted'": 4,
    'echo "dq"': 5,
    "foxtrot": 6,
    "golf": 7,
    "hotel": 8,
    "india": 9,
}
LEGACY = "juliet_legacy_noclearance"  # KiCad 5 file, Default clearance 0: kept, 2 nets
EXPECTED_FATES = {
    **{name: "kept" for name in KEPT_NAMES},
    LEGACY: "kept",
    "kilo_shorted": "drc_failure",
    "lima_open": "not_connected",
    "mike_no_board": "missing_input",
    "november_no_final": "missing_input",
    "oscar_truncated": "load_failure",
    "papa_garbage": "load_failure",
    "quebec_bad_final": "load_failure",
    "romeo_nonutf8": "load_failure",
    "sierra_excluded": "excluded_by_override",
}


def make_corpus(root: Path) -> Path:
    """Writes the fixture corpus under `root`; returns `root`."""
    root.mkdir(parents=True, exist_ok=True)
    github_items = []
    for i, (name, nets) in enumerate(KEPT_NAMES.items()):
        board = row_board(nets, f"fixture/{name}")
        repo = f"https://github.com/owner{i}/repo{i}"
        # odd boards carry their licence in metadata.json, even ones only in github_meta
        _folder(root, name, board_text(board).encode(), final_json(board), repo,
                MIT if i % 2 else None)
        github_items.append({"html_url": repo, "owner": {"login": f"owner{i}"},
                             "license": None if i % 2 or name == "india" else
                             {"key": "gpl-3.0", "spdx_id": "GPL-3.0",
                              "name": "GNU General Public License v3.0"}})
    _folder(root, LEGACY, legacy_board_text().encode(), legacy_final_json(),
            "https://github.com/j/j", MIT)
    shorted = row_board(3, "fixture/kilo", short=True)
    _folder(root, "kilo_shorted", board_text(shorted).encode(), final_json(shorted),
            "https://github.com/k/k")
    opened = row_board(3, "fixture/lima", unrouted_nets=1)
    _folder(root, "lima_open", board_text(opened).encode(), final_json(opened),
            "https://github.com/l/l")
    plain = row_board(2, "fixture/plain")
    text = board_text(plain).encode()
    _folder(root, "mike_no_board", None, final_json(plain), "https://github.com/m/m")
    _folder(root, "november_no_final", text, None, "https://github.com/n/n")
    _folder(root, "oscar_truncated", text[: len(text) // 2], final_json(plain),
            "https://github.com/o/o")
    _folder(root, "papa_garbage", b"this is not a board\n" * 20, final_json(plain),
            "https://github.com/p/p")
    _folder(root, "quebec_bad_final", text, b'{"nets": {"1": [', "https://github.com/q/q")
    _folder(root, "romeo_nonutf8", text.replace(b"(kicad_pcb", b"\xff\xfe(kicad_pcb \xc3\x28", 1),
            final_json(plain), "https://github.com/r/r")
    _folder(root, "sierra_excluded", text, final_json(plain), "https://github.com/s/s")
    (root / "github_meta").mkdir()
    (root / "github_meta" / "github_1.json").write_text(
        json.dumps({"total_count": len(github_items), "items": github_items}))
    (root / "LICENSE").write_text("MIT License\n\nCopyright (c) 2023 PCBench\n")
    return root


def fixture_recipe(path: Path) -> Path:
    """The packaged recipe scaled down to the fixture: A = 3 boards, B = pads <= 12,
    2 bins, no published test lists (the fixture has none of those boards), boards with open
    connections dropped (`max_unconnected = 0`, to exercise the `not_connected` fate), plus an
    exclusion override."""
    import re

    from pcbdata.resources import resource_path

    text = resource_path("recipes", "d3.toml").read_text()
    text = text.replace("a_size = 100", "a_size = 3").replace("b_max_pads = 100",
                                                              "b_max_pads = 12")
    text = text.replace("bins = 10", "bins = 2").replace('version = "2.0.0"',
                                                         'version = "2.0.0-fixture"')
    text = text.replace("max_errors = 0\n", "max_errors = 0\nmax_unconnected = 0\n")
    text = re.sub(r"\[published\]\n(?:.*\n)*?\]\n(?:.*\n)*?\]\n", "", text)
    assert "[published]" not in text and "max_unconnected = 0" in text
    text = text.replace("task_timeout_s = 300", "task_timeout_s = 120")
    text += ('\n[[overrides]]\nkind = "exclude"\nboard = "sierra_excluded"\n'
             'reason = "fixture: exercise the exclusion override"\n')
    path.write_text(text)
    return path

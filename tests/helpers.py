"""Small helpers shared by tests: writing boards and reading them back with sexpdata."""
from __future__ import annotations

from pathlib import Path

import sexpdata

from pcbdata.model.kicad_writer import board_files


def write_board(folder: Path, board) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in board_files(board).items():
        (folder / name).write_text(text)
    return folder / "board.kicad_pcb"


def _head(node) -> str | None:
    if isinstance(node, list) and node and isinstance(node[0], sexpdata.Symbol):
        return node[0].value()
    return None


def _child(node, name: str):
    return next((c for c in node if _head(c) == name), None)


def parse_board(path: Path) -> list:
    return sexpdata.loads(Path(path).read_text())


def pads_in_file(path: Path) -> list[dict]:
    """Pads of a board file written by pcbdata: centre (mm), layer, type, shape, size, net."""
    out = []
    for node in parse_board(path):
        if _head(node) != "footprint":
            continue
        x, y = _child(node, "at")[1:3]
        pad = _child(node, "pad")
        out.append({"x": float(x), "y": float(y), "footprint_layer": _child(node, "layer")[1],
                    "type": pad[2].value(), "shape": pad[3].value(),
                    "size": tuple(float(v) for v in _child(pad, "size")[1:3]),
                    "layers": list(_child(pad, "layers")[1:]),
                    "drill": float(_child(pad, "drill")[1]) if _child(pad, "drill") else None,
                    "net": _child(pad, "net")[2]})
    return out


def outline_in_file(path: Path) -> tuple[tuple[float, float], tuple[float, float], str]:
    rect = next(n for n in parse_board(path) if _head(n) == "gr_rect")
    start, end = _child(rect, "start")[1:3], _child(rect, "end")[1:3]
    layer = _child(rect, "layer")[1]
    return (float(start[0]), float(start[1])), (float(end[0]), float(end[1])), layer

def with_straight_tracks(board, unrouted_every: int = 3):
    """A quickly "routed" copy of a generated board: each net's pads chained by straight tracks
    (through a via where the chain changes copper layer), every `unrouted_every`-th net left
    bare. The tracks cross freely, so KiCad's track checks find many shorts and clearance
    violations, next to the unconnected items of the bare nets."""
    import dataclasses

    from pcbdata.model.board import Track, Via

    tracks, vias = [], []
    width, rules = board.rules.track_width, board.rules
    for k, net in enumerate(board.net_names):
        if k % unrouted_every == unrouted_every - 1:
            continue
        pads = [p for p in board.pads if p.net == net]
        for a, b in zip(pads, pads[1:]):
            layer_a = None if a.kind == "thru_round" else a.layer
            layer_b = None if b.kind == "thru_round" else b.layer
            if layer_a is None or layer_b is None or layer_a == layer_b:
                tracks.append(Track(a.x, a.y, b.x, b.y, width, net, layer_a or layer_b or "F.Cu"))
                continue
            mx, my = (a.x + b.x) // 2, (a.y + b.y) // 2
            tracks += [Track(a.x, a.y, mx, my, width, net, layer_a),
                       Track(mx, my, b.x, b.y, width, net, layer_b)]
            vias.append(Via(mx, my, rules.via_diameter, rules.via_drill, net))
    return dataclasses.replace(board, tracks=tracks, vias=vias)


def drc_in_workers(paths: list, enabled: bool, workers: int = 2) -> list[dict]:
    """`fastwait.timed_drc` of each board (a path, or a (board, project) pair to check it under
    that project's rules) in a fresh KicadPool whose workers start with the DRC-wait preload
    (enabled) or without it; results in the order of `paths`."""
    from pcbdata.kicad import KicadPool, fastwait

    env = fastwait.preload_env(enabled)  # applied at the workers' exec
    with KicadPool(workers=workers, task_timeout=300, env=env) as pool:
        outcomes = list(pool.map("pcbdata.kicad.fastwait:timed_drc",
                                 [(p,) if isinstance(p, str) else tuple(p) for p in paths]))
    failed = [(paths[o.index], o.error) for o in outcomes if not o.ok]
    assert not failed, failed
    return [o.value for o in sorted(outcomes, key=lambda o: o.index)]


def drc_parity(paths: list, reruns: int = 6) -> dict:
    """DRC of every board without and with the DRC-wait preload, compared in
    `fastwait.canonical_violations` form.

    KiCad's DRC is not fully repeatable on some boards even without the preload (e.g. which
    Edge.Cuts segments an `invalid_outline` names). A board whose two results differ is checked
    again `reruns` times in each mode: if some result occurs in both modes, the difference is
    KiCad's own variation ("kicad_varies"); if none does, the preload changed it ("different").
    """
    from pcbdata.kicad.fastwait import canonical_violations

    def outcome(result) -> tuple:
        report = result["report"]
        return tuple(canonical_violations(report)), tuple(sorted(report["declared_counts"].items()))

    slow = drc_in_workers(paths, enabled=False)
    fast = drc_in_workers(paths, enabled=True)
    suspects = [p for p, a, b in zip(paths, slow, fast) if outcome(a) != outcome(b)]
    varies, different = [], []
    if suspects:
        again = [p for p in suspects for _ in range(reruns)]
        slow_again = drc_in_workers(again, enabled=False)
        fast_again = drc_in_workers(again, enabled=True)
        for k, path in enumerate(suspects):
            i = paths.index(path)
            chunk = slice(k * reruns, (k + 1) * reruns)
            seen_slow = {outcome(r) for r in [slow[i], *slow_again[chunk]]}
            seen_fast = {outcome(r) for r in [fast[i], *fast_again[chunk]]}
            (varies if seen_slow & seen_fast else different).append(path)
    return {"slow": slow, "fast": fast, "identical": len(paths) - len(suspects),
            "kicad_varies": varies, "different": different}


def seal_set(root: Path) -> Path:
    """Writes the manifest of a hand-made set (`root/<config>/<split>/<board>/<files>`) as a
    build would, listing every file on disk with its sha256, so the evaluator and the
    environment take it as a verified set. A config the registry knows records its family,
    version, seed and parameters; the others are `d2` boards under another name."""
    from pcbdata.core.errors import UserError
    from pcbdata.core.hashing import sha256_file
    from pcbdata.model.manifest import FORMAT, write_manifest
    from pcbdata.spec.configs import get_config

    configs: dict = {}
    for split_dir in sorted(p for p in Path(root).glob("*/*") if p.is_dir()):
        boards = {b.name: {"files": {f.name: sha256_file(f) for f in sorted(b.iterdir())}}
                  for b in sorted(split_dir.iterdir()) if b.is_dir()}
        name = split_dir.parent.name
        if name not in configs:
            try:
                spec = get_config(name)
                configs[name] = {"family": spec.family, "set_version": spec.version,
                                 "seed": spec.seed, "parameters": spec.parameters,
                                 **spec.manifest, "splits": {}}
            except UserError:
                configs[name] = {"family": "d2", "set_version": "test", "splits": {}}
        configs[name]["splits"][split_dir.name] = {"boards": boards, "count": len(boards)}
    write_manifest(root, {"format": FORMAT, "package_version": "test", "configs": configs})
    return Path(root)

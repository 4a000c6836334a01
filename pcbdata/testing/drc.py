"""Boards with many DRC violations, and KiCad's DRC run with and without the DRC-wait preload
(`pcbdata.kicad.fastwait`): shared by its tests and its benchmark."""
from __future__ import annotations


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
    varies: list = []
    different: list = []
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

"""Run inside a KiCad worker by `test_clusters.py`: the environment's snapshot of a routed board
next to the evaluator's own per-net cluster count."""
from __future__ import annotations

import tempfile


def env_and_evaluator_clusters(board: str, project: str, rules: str | None) -> dict:
    from pcbdata.evaluator.metrics import STRICT_WARNINGS
    from pcbdata.kicad import routing_session
    from pcbdata.kicad.scoring import pad_clusters

    with tempfile.TemporaryDirectory() as stage:
        opened = routing_session.open_instance(board, project, rules, stage,
                                                sorted(STRICT_WARNINGS))
        snap = opened["snapshot"]
        nets = [pad["net"] for pad in opened["static"]["pads"]]
        labels: dict[str, set[int]] = {}
        for net, label in zip(nets, snap["pad_cluster"]):
            if net:
                labels.setdefault(net, set()).add(label)
        result = {"snapshot": snap["clusters"], "labels": {n: len(v) for n, v in labels.items()},
                  "evaluator": pad_clusters(routing_session._board())}
        routing_session.close()
    return result

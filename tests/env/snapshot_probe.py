"""Run inside a KiCad worker by `test_clusters.py`: a routed real board's tracks and vias laid
again on its unrouted instance in batches, some taken up, the rest pruned; after every edit the
environment's snapshot (which remembers links and records between steps) next to the same
measurements worked out afresh, and before the pruning the snapshot of the connectivity kept
up step by step next to one of a connectivity rebuilt from scratch."""
from __future__ import annotations

import tempfile


def _fresh() -> dict:
    """The snapshot's copper, clusters and totals, worked out without any memory."""
    from pcbdata.kicad import routing_session
    from pcbdata.kicad.board_reading import track_record
    from pcbdata.kicad.scoring import copper_labels, copper_totals

    board = routing_session._board()
    pads, tracks = routing_session._STATE["pads"], list(board.GetTracks())
    labels = copper_labels(board, pads + tracks + list(board.Zones()))
    names = {lid: name for name, lid in routing_session._STATE["layers"].items()}
    wl_mm, vias = copper_totals(board)
    return {"copper": [track_record(t, names, labels[len(pads) + i])
                       for i, t in enumerate(tracks)],
            "pad_cluster": labels[:len(pads)], "wl_mm": wl_mm, "vias": vias}


def snapshots_agree(board: str, project: str, rules: str | None, reference: str) -> dict:
    """How many snapshots were compared, and the steps whose snapshot differs from afresh."""
    from pcbdata.evaluator.metrics import STRICT_WARNINGS
    from pcbdata.kicad import routing_session

    keys = ("copper", "pad_cluster", "wl_mm", "vias")
    differ, compared = [], 0
    with tempfile.TemporaryDirectory() as stage, tempfile.TemporaryDirectory() as folder:
        edits = routing_session.copper_edits(reference, folder)
        routing_session.open_instance(board, project, rules, stage, sorted(STRICT_WARNINGS))
        laid = []
        for start in range(0, len(edits), 7):
            batch = edits[start:start + 7]
            snap = routing_session.apply(batch)
            laid += [e for e in batch if e["kind"] == "track"]
            compared += 1
            if {k: snap[k] for k in keys} != _fresh():
                differ.append(f"apply {start}")
        for k, edit in enumerate(laid[::3]):  # take up every third track laid
            snap = routing_session.apply([{"kind": "remove", "net": edit["net"],
                                           "layer": edit["layer"], "start": edit["points"][0],
                                           "end": edit["points"][1], "width": edit["width"]}])
            compared += 1
            if {k: snap[k] for k in keys} != _fresh():
                differ.append(f"remove {k}")
        # the connectivity kept up step by step (`apply`) against one rebuilt from scratch
        kept = routing_session.snapshot(False)
        routing_session._board().BuildConnectivity()
        rebuilt = routing_session.snapshot(False)
        compared += 1
        if any(kept[k] != rebuilt[k] for k in (*keys, "clusters", "unconnected")):
            differ.append("kept connectivity")
        pruned = routing_session.prune(sorted({e["net"] for e in edits}))
        if pruned["snapshot"] is not None:
            compared += 1
            if {k: pruned["snapshot"][k] for k in keys} != _fresh():
                differ.append("prune")
        routing_session.close()
    return {"compared": compared, "differ": differ, "edits": len(edits)}

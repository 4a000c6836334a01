"""The environment's clean-up (`routing_session.prune`): a track with a free end whose body
still joins its net where a track of the net crosses it is shortened to that crossing, not left
dangling (before, deleting it cut the net and the clean-up was undone, so the stub stayed and
KiCad's DRC flagged it: d2-hard board_00083 after a push_n_shove)."""
from __future__ import annotations

import tempfile
from pathlib import Path

from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE

WIDTH = 250_000


def crossing_tracks_pruned(instance: str) -> dict:
    """Worker side: on the instance, a track from each pad of a two-pad net (pads on one side)
    runs straight past the point J where they cross (level with one pad, above the other);
    the net's clean-up."""
    from pcbdata.evaluator.metrics import STRICT_WARNINGS
    from pcbdata.kicad import routing_session

    with tempfile.TemporaryDirectory() as stage:
        opened = routing_session.open_instance(str(Path(instance) / BOARD_FILE),
                                               str(Path(instance) / PROJECT_FILE), None,
                                               stage, sorted(STRICT_WARNINGS))
        pads = opened["static"]["pads"]
        a, b = next(pair for net in sorted({p["net"] for p in pads if p["net"]})
                    for pair in [[p for p in pads if p["net"] == net]]
                    if len(pair) == 2 and set(pair[0]["layers"]) & set(pair[1]["layers"])
                    and abs(pair[0]["x"] - pair[1]["x"]) > 2_000_000
                    and abs(pair[0]["y"] - pair[1]["y"]) > 2_000_000)
        layer = sorted(set(a["layers"]) & set(b["layers"]))[0]
        joint = (b["x"], a["y"])
        beyond = [(joint[0] + (joint[0] - a["x"]) // 4, a["y"]),
                  (b["x"], joint[1] + (joint[1] - b["y"]) // 4)]
        tracks = [{"kind": "track", "net": a["net"], "layer": layer, "width": WIDTH,
                   "points": points}
                  for points in ([(a["x"], a["y"]), beyond[0]], [(b["x"], b["y"]), beyond[1]])]
        routing_session.apply(tracks)
        pruned = routing_session.prune([a["net"]], drc=True)
        again = routing_session.prune([a["net"]], drc=True)
        routing_session.close()
    return {"net": a["net"], "starts": [(a["x"], a["y"]), (b["x"], b["y"])], "beyond": beyond,
            "joint": joint, "pruned": pruned, "again": again}


def test_tracks_running_past_their_crossing_are_shortened_to_it(board_set, kicad_pool):
    instance = board_set / "d2" / "test" / "board_00000"
    outcome = next(iter(kicad_pool.map(f"{__name__}:crossing_tracks_pruned",
                                       [(str(instance),)])))
    assert outcome.ok, outcome.error
    result = outcome.value
    snapshot = result["pruned"]["snapshot"]
    ends = {tuple(end) for r in snapshot["copper"] if r["net"] == result["net"]
            for end in (r["start"], r["end"])}
    assert ends == {*result["starts"], result["joint"]}  # no stub past the crossing
    assert snapshot["clusters"][result["net"]] == 1
    assert not [v for v in snapshot["violations"] if v["type"] == "track_dangling"]
    assert result["again"]["edits"] == []


def test_no_stub_stays_where_a_push_n_shove_reroute_crossed_it(tmp_path):
    # d2-hard board_00083, scripted-shove: the last push_n_shove rerouted NET12 across one of
    # its own tracks, whose far end then touched nothing; deleting that track split the net,
    # so the clean-up was undone and KiCad's DRC counted a dangling track (CP+ < CP).
    import pcbdata.env
    from pcbdata.agents.registry import make_agent
    from pcbdata.runners.rollout import run_episode
    from pcbdata.testing.sets import write_set

    write_set(tmp_path, "d2-hard", "test", 84)
    env = pcbdata.env.make(tmp_path, "d2-hard", split="test", drc="terminal")
    try:
        record = run_episode(env, make_agent("scripted-shove", 0), "board_00083", 0)
        violations = env.unwrapped.violations
    finally:
        env.close()
    assert record["terminated"]
    assert violations == []  # every pad joined, nothing dangling

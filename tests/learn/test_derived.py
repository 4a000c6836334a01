"""The policy's derived inputs on a real D2 board: they mark what the scripted agent's choices
depend on (so cloning can match them), and the memory notices an action that changed nothing."""
from __future__ import annotations

import numpy as np
import pytest

from pcbdata.agents.scripted import ScriptedAgent
from pcbdata.env.types import FINISH, NET_SELECT, START_ROUTE, WALKAROUND
from pcbdata.env.wrappers import features as F
from pcbdata.env.wrappers.rl import make_rl_env
from pcbdata.learn import batch as batching
from pcbdata.learn import derived as D
from pcbdata.learn.train import triple_of


@pytest.fixture(scope="module")
def scripted_episode():
    """(wrapped observation, derived rows, scripted triple) of every step of one D2 episode."""
    env = make_rl_env("d2", split="train", count=2, max_steps=60, drc="terminal")
    raw_env = env.unwrapped
    layout = F.Layout.from_options(raw_env.options)
    raw, info = raw_env.reset(seed=0, options={"index": 1})
    static = F.static_rows(raw, layout)
    agent, reader, steps, done = ScriptedAgent(seed=0), D.EpisodeReader(), [], False
    try:
        while not done and not getattr(agent, "done", False):
            act = agent.act(raw, info)
            wrapped = batching.wrapped_observation(raw, info["action_mask"], layout, static)
            extra, t = reader.read(wrapped), triple_of(act)
            steps.append((wrapped, extra, t))
            reader.acted(t)
            raw, _, term, trunc, info = raw_env.step(act)
            done = term or trunc
    finally:
        env.close()
    assert info["unconnected"] == 0  # the scripted agent routes this board
    return steps


def _rows(wrapped, family):
    return np.flatnonzero(np.asarray(wrapped["entity_type"]) == family)


def test_scripted_starts_sit_on_the_shortest_open_edge_end(scripted_episode):
    starts = [(w, x, t) for w, x, t in scripted_episode if t[0] == START_ROUTE]
    assert starts
    for wrapped, extra, t in starts:
        cands = _rows(wrapped, F.CANDIDATE)
        chosen = extra[cands[t[1]]]
        assert chosen[D.CAND0 + 2] == 1.0  # an end of an open edge of the head's net
        ends = extra[cands][:, D.CAND0 + 2] == 1.0
        assert chosen[D.CAND0 + 4] == extra[cands][ends, D.CAND0 + 4].min()


def test_scripted_selects_the_smallest_open_net(scripted_episode):
    selects = [(w, x, t) for w, x, t in scripted_episode if t[0] == NET_SELECT]
    assert len(selects) >= 3
    for wrapped, extra, t in selects:
        nets = _rows(wrapped, F.NET)
        open_ = (extra[nets, D.NET0] > 0) & np.asarray(wrapped["index_mask"])[NET_SELECT,
                                                                           : len(nets)].astype(bool)
        assert open_[t[1]]
        assert extra[nets[t[1]], D.NET0 + 2] == extra[nets][open_, D.NET0 + 2].min()
        assert extra[nets[t[1]], D.NET0 + 3] == 0.0  # never selected before in this episode


def test_memory_marks_a_finish_that_changed_nothing(scripted_episode):
    wrapped = next(w for w, _, t in scripted_episode if t[0] == FINISH)
    reader = D.EpisodeReader()
    first = reader.read(wrapped)
    head = _rows(wrapped, F.HEAD)[0]
    failed_here = D.HEAD0 + len(D.ACTION_TYPES) + len(D.MODES) + 1 + WALKAROUND
    assert first[head, failed_here] == 0.0
    reader.acted((FINISH, 0, WALKAROUND))
    later = dict(wrapped)  # the same board one step later: only the step counters moved
    later["entities"] = np.array(wrapped["entities"])
    later["entities"][_rows(wrapped, F.BOARD)[0], F.B] += 0.25
    later["entities"][head, F.COUNT] += 1
    again = reader.read(later)
    assert again[head, D.HEAD0 + FINISH] == 1.0 and again[head, failed_here] == 1.0
    assert again[head, D.HEAD0 + len(D.ACTION_TYPES) + len(D.MODES)] == 1.0  # changed nothing


def test_fingerprint_sees_copper_but_not_step_counters(scripted_episode):
    def laid(wrapped) -> np.ndarray:
        return np.flatnonzero((np.asarray(wrapped["entity_type"]) == F.TRACK)
                              & np.asarray(wrapped["entity_mask"]).astype(bool))

    wrapped = next(w for w, _, _ in scripted_episode if len(laid(w)))
    moved = dict(wrapped, entities=np.array(wrapped["entities"]))
    moved["entities"][_rows(wrapped, F.HEAD)[0], F.COUNT] += 3
    assert D.fingerprint(moved) == D.fingerprint(wrapped)
    track = laid(wrapped)[0]
    moved["entities"][track, F.X1] += 0.01
    assert D.fingerprint(moved) != D.fingerprint(wrapped)


def test_acted_without_read_is_an_error():
    with pytest.raises(RuntimeError, match="without read"):
        D.EpisodeReader().acted((0, 0, 0))

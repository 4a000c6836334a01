"""The set policy on hand-made batches (no KiCad): masks honoured head by head, one network for
any number of rows, nets and candidates, pointer indices addressing the right block."""
from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pcbdata.env.types import FINISH, IDLE, MAKE_LINE, MAKE_VIA, NET_SELECT  # noqa: E402
from pcbdata.learn import batch as batching  # noqa: E402
from pcbdata.learn.policy import SetPolicy, device, to_tensors  # noqa: E402


def _item(rng, n_nets: int, n_cands: int, extra: int, k: int) -> dict:
    rows = n_nets + n_cands + extra
    index = np.zeros((7, k), dtype=bool)
    mode = np.zeros((7, 3), dtype=bool)
    index[IDLE, 0] = mode[IDLE, 0] = True
    index[NET_SELECT, rng.choice(n_nets, 3, replace=False)] = True
    mode[NET_SELECT, 0] = True
    index[MAKE_LINE, rng.choice(n_cands, 5, replace=False)] = True
    index[MAKE_VIA, rng.choice(n_cands, 1)] = True
    mode[MAKE_LINE, 1] = mode[MAKE_VIA, 2] = True
    index[FINISH, 0] = True
    mode[FINISH, [0, 2]] = True
    return {"x": rng.normal(size=(rows, batching.WIDTH)).astype(np.float32),
            "valid": rng.random(rows) < 0.8, "n_nets": np.int64(n_nets),
            "n_cands": np.int64(n_cands), "index_mask": index, "mode_mask": mode}


@pytest.mark.parametrize(("n_nets", "n_cands", "k"), [(32, 64, 64), (1024, 64, 1024)])
def test_sampled_actions_are_never_masked(n_nets, n_cands, k):
    rng = np.random.default_rng(0)
    dev = device()  # one torch thread on the CPU, as in training
    policy = SetPolicy(dim=16).to(dev)
    items = [_item(rng, n_nets, n_cands, extra, k) for extra in (3, 40, 200, 7)]
    batch = to_tensors(batching.collate(items), dev)
    gen = torch.Generator(device=dev).manual_seed(0)
    seen = set()
    for step in range(25):
        actions, logp, value = policy.act(batch, generator=gen, temperature=1.0 + step % 3)
        for item, (t, i, m) in zip(items, actions.tolist(), strict=True):
            assert item["index_mask"][t, i] and item["mode_mask"][t, m], (t, i, m)
            seen.add(t)
        assert torch.isfinite(logp).all() and logp.max() <= 0 and value.shape == (4,)
    assert seen == {IDLE, NET_SELECT, MAKE_LINE, MAKE_VIA, FINISH}


@pytest.mark.parametrize("temperature", [1.0, 2.0, 3.0])
def test_evaluate_matches_act_and_masked_actions_are_impossible(temperature):
    """At every sampling temperature: `act` reports the untempered policy's log-probabilities
    (those `evaluate` gives), and a masked action stays impossible, untempered and tempered."""
    rng = np.random.default_rng(1)
    policy = SetPolicy(dim=16)
    batch = to_tensors(batching.collate([_item(rng, 32, 64, 10, 64)]), torch.device("cpu"))
    actions, logp, _ = policy.act(batch, generator=torch.Generator().manual_seed(3),
                                  temperature=temperature)
    again, entropy, _ = policy.evaluate(batch, actions)
    assert torch.allclose(logp, again) and entropy.item() > 0
    masked = np.flatnonzero(~batch["index_mask"][0, NET_SELECT].numpy())[0]
    bad, _, _ = policy.evaluate(batch, torch.tensor([[NET_SELECT, int(masked), 0]]))
    assert bad.item() < -1e6
    h, s = policy.encode(batch)
    logits = policy.index_logits(h, s, torch.tensor([NET_SELECT]), batch)
    assert torch.log_softmax(logits / temperature, dim=-1)[0, masked].item() < -1e6


def test_pointer_reads_net_rows_for_net_select_and_candidate_rows_otherwise():
    """With one allowed net and one allowed candidate, the index follows the type's block."""
    rng = np.random.default_rng(2)
    item = _item(rng, 32, 64, 5, 64)
    item["index_mask"][:] = False
    item["mode_mask"][:] = False
    item["index_mask"][NET_SELECT, 17] = item["mode_mask"][NET_SELECT, 0] = True
    batch = to_tensors(batching.collate([item]), torch.device("cpu"))
    actions, _, _ = SetPolicy(dim=16).act(batch, greedy=True)
    assert actions.tolist() == [[NET_SELECT, 17, 0]]
    item["index_mask"][NET_SELECT] = False
    item["index_mask"][MAKE_LINE, 40] = item["mode_mask"][MAKE_LINE, 1] = True
    batch = to_tensors(batching.collate([item]), torch.device("cpu"))
    actions, _, _ = SetPolicy(dim=16).act(batch, greedy=True)
    assert actions.tolist() == [[MAKE_LINE, 40, 1]]

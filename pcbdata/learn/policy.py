"""The set policy (docs/learn.md): the same weights for any board size.

Rows are embedded one by one, then two DeepSets rounds (each row sees a masked max- and
mean-pool of all rows) give row features and a board summary (the pools and the head row,
which carries the agent's memory: `pcbdata.learn.derived`). Heads, autoregressive:
type from the summary (masked by the types that have an allowed index), a pointer over the
net rows (`net_select`) or the candidate rows (`start_route`, `make_line`, `make_via`) queried by
summary and type, the mode from summary and type; each masked by that type's row of
`index_mask` / `mode_mask`, so a masked combination is never drawn. A type that reads no
index (mode) has only 0 allowed: its index (mode) costs no log-probability.
"""
from __future__ import annotations

import torch
from torch import nn

from pcbdata.env.types import ACTION_TYPES, MODES, NET_SELECT
from pcbdata.learn.batch import WIDTH

N_TYPES, N_MODES = len(ACTION_TYPES), len(MODES)
NEG = -1e9


def _mlp(n_in: int, n_out: int, hidden: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(n_in, hidden), nn.ReLU(), nn.Linear(hidden, n_out))


def _pool(h: torch.Tensor, valid: torch.Tensor) -> torch.Tensor:
    """Masked max and mean over rows: [B, L, D] -> [B, 2D]."""
    m = valid.unsqueeze(-1)
    top = h.masked_fill(~m, NEG).amax(dim=1)
    top = torch.where(valid.any(dim=1, keepdim=True), top, torch.zeros_like(top))
    mean = (h * m).sum(dim=1) / m.sum(dim=1).clamp(min=1)
    return torch.cat((top, mean), dim=-1)


class SetPolicy(nn.Module):
    """Actor and critic over a `batch.collate` batch (tensors)."""

    def __init__(self, dim: int = 64):
        super().__init__()
        self.dim = dim
        self.embed = _mlp(WIDTH, dim, dim)
        self.round1 = _mlp(3 * dim, dim, dim)
        self.round2 = _mlp(3 * dim, dim, dim)
        self.summary = _mlp(3 * dim, dim, dim)
        self.type_head = nn.Linear(dim, N_TYPES)
        self.type_embed = nn.Embedding(N_TYPES, dim)
        self.query = _mlp(2 * dim, dim, dim)
        self.key = nn.Linear(dim, dim)
        self.mode_head = _mlp(2 * dim, N_MODES, dim)
        self.value_head = _mlp(dim, 1, dim)

    def encode(self, batch: dict) -> tuple[torch.Tensor, torch.Tensor]:
        """(row features [B, L, D], board summary [B, D])."""
        x, valid = batch["x"], batch["valid"]
        h = torch.relu(self.embed(x))
        for layer in (self.round1, self.round2):
            g = _pool(h, valid).unsqueeze(1).expand(-1, h.shape[1], -1)
            h = h + torch.relu(layer(torch.cat((h, g), dim=-1)))
        head = h[:, batch["n_nets"] + batch["n_cands"]]
        return h, torch.relu(self.summary(torch.cat((_pool(h, valid), head), dim=-1)))

    def type_logits(self, s: torch.Tensor, batch: dict) -> torch.Tensor:
        allowed = batch["index_mask"].any(dim=-1)
        return self.type_head(s).masked_fill(~allowed, NEG)

    def index_logits(self, h, s, kind, batch) -> torch.Tensor:
        """Pointer scores over the K index slots for the chosen types: net rows for
        net_select, candidate rows otherwise, masked by the type's row of index_mask."""
        n_nets, n_cands = batch["n_nets"], batch["n_cands"]
        k = batch["index_mask"].shape[-1]
        q = self.query(torch.cat((s, self.type_embed(kind)), dim=-1))
        keys = self.key(h[:, : n_nets + n_cands])
        scores = torch.einsum("bd,bld->bl", q, keys) / self.dim ** 0.5
        pad = scores.new_full((scores.shape[0], k), NEG)
        nets, cands = pad.clone(), pad.clone()
        nets[:, :n_nets] = scores[:, :n_nets]
        cands[:, :n_cands] = scores[:, n_nets:]
        logits = torch.where((kind == NET_SELECT).unsqueeze(-1), nets, cands)
        rows = batch["index_mask"][torch.arange(len(kind)), kind]
        return logits.masked_fill(~rows, NEG)

    def mode_logits(self, s, kind, batch) -> torch.Tensor:
        logits = self.mode_head(torch.cat((s, self.type_embed(kind)), dim=-1))
        rows = batch["mode_mask"][torch.arange(len(kind)), kind]
        return logits.masked_fill(~rows, NEG)

    def act(self, batch: dict, greedy: bool = False, generator: torch.Generator | None = None,
            temperature: float = 1.0):
        """(actions [B, 3], log-probabilities [B], values [B]) drawn (or argmax) head by head;
        `temperature` divides the logits before sampling (masked entries stay impossible); the
        log-probabilities are the untempered policy's."""
        h, s = self.encode(batch)
        kind = _choose(self.type_logits(s, batch), greedy, generator, temperature)
        index = _choose(self.index_logits(h, s, kind, batch), greedy, generator, temperature)
        mode = _choose(self.mode_logits(s, kind, batch), greedy, generator, temperature)
        actions = torch.stack((kind, index, mode), dim=-1)
        logp, _ = self._logp(h, s, actions, batch)
        return actions, logp, self.value_head(s).squeeze(-1)

    def evaluate(self, batch: dict, actions: torch.Tensor):
        """(log-probabilities, entropies, values) of given actions."""
        h, s = self.encode(batch)
        logp, entropy = self._logp(h, s, actions, batch)
        return logp, entropy, self.value_head(s).squeeze(-1)

    def _logp(self, h, s, actions, batch):
        kind, index, mode = actions.unbind(-1)
        heads = (self.type_logits(s, batch), self.index_logits(h, s, kind, batch),
                 self.mode_logits(s, kind, batch))
        logp = torch.zeros(len(kind), device=kind.device)
        entropy = torch.zeros_like(logp)
        for logits, chosen in zip(heads, (kind, index, mode), strict=True):
            lp = torch.log_softmax(logits, dim=-1)
            logp = logp + lp.gather(-1, chosen.unsqueeze(-1)).squeeze(-1)
            entropy = entropy - (lp.exp() * lp).sum(dim=-1)
        return logp, entropy


def _choose(logits: torch.Tensor, greedy: bool, generator, temperature: float = 1.0
            ) -> torch.Tensor:
    if greedy:
        return logits.argmax(dim=-1)
    probs = torch.softmax(logits / temperature, dim=-1)
    return torch.multinomial(probs, 1, generator=generator).squeeze(-1)


def to_tensors(batch: dict, device: torch.device) -> dict:
    """A `batch.collate` result on `device` (ints stay ints)."""
    return {k: torch.as_tensor(v, device=device) if not isinstance(v, int) else v
            for k, v in batch.items()}


def device() -> torch.device:
    """The GPU when one is present, else the CPU, with one torch thread: the batches are
    small and the environments' processes need the other cores (two threads made a step
    three times slower on the shared 2-core machine)."""
    if torch.cuda.is_available():
        return torch.device("cuda")
    torch.set_num_threads(1)
    return torch.device("cpu")

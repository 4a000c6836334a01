"""The agents by name (`pcbdata rollout --agent NAME`): the registry and `make_agent`.

Each name maps to a `module:Class`; the learned policy is one of them (`policy`, or
`policy:CHECKPOINT` for another checkpoint). Any other `module:Class` with `act(obs, info)` is
an agent too.
"""
from __future__ import annotations

import importlib
import inspect

from pcbdata.core.errors import UserError

AGENTS = {"scripted": "pcbdata.agents.scripted:ScriptedAgent",
          "scripted-shove": "pcbdata.agents.scripted:ShovingScriptedAgent",
          "random": "pcbdata.agents.random:RandomAgent",
          "d1": "pcbdata.agents.d1:D1Agent",
          "llm": "pcbdata.agents.llm_agents:LLMAgent",
          "llm-plan": "pcbdata.agents.llm_agents:PlanAgent",
          "llm-direct": "pcbdata.agents.llm_agents:DirectAgent",
          "llm-paper": "pcbdata.agents.llm_paper:PaperAgent",
          "llm-paper-plan": "pcbdata.agents.llm_paper:PaperPlanAgent",
          "llm-paper-direct": "pcbdata.agents.llm_paper:PaperDirectAgent",
          "policy": "pcbdata.learn.agent:PolicyAgent",
          "negotiated": "pcbdata.agents.negotiated:NegotiatedAgent"}


def make_agent(spec: str, seed: int, options: dict | None = None):
    """An agent by name (`AGENTS`: scripted, scripted-shove, random, d1, llm, llm-plan,
    llm-direct, llm-paper, llm-paper-plan, llm-paper-direct, policy, negotiated),
    `policy:CHECKPOINT` (the learned router with another checkpoint) or `module:Class`;
    seeded when it takes one; `options` (plain data, e.g. a language model's server and
    sampling) are passed as keyword arguments."""
    if spec.startswith("policy:"):
        return _policy_agent(spec.partition(":")[2], seed)
    ref = AGENTS.get(spec, spec)
    module, _, name = ref.partition(":")
    if not name:
        raise UserError(f"--agent {spec!r}: use {', '.join(AGENTS)} or module:Class")
    try:
        cls = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise UserError(f"--agent {spec!r}: {exc}") from None
    parameters = inspect.signature(cls).parameters
    kwargs = {"seed": seed} if "seed" in parameters else {}
    if options:
        if not any(p.kind is p.VAR_KEYWORD for p in parameters.values()):
            raise UserError(f"--agent {spec!r} takes no language-model options "
                            f"({', '.join(sorted(options))})")
        kwargs.update(options)
    return cls(**kwargs)


def _policy_agent(path: str, seed: int):
    """The learned router with the checkpoint at `path`; named by its `AGENTS` entry (a
    string, like every agent here: the registry imports no agent's room)."""
    module, _, name = AGENTS["policy"].partition(":")
    try:
        cls = getattr(importlib.import_module(module), name)
    except ImportError as exc:
        raise UserError(f"--agent policy:{path}: needs the train extra (torch): {exc}") from None
    return cls(seed=seed, path=path)

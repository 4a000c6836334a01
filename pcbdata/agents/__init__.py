"""Agents that route boards through the environment's actions (`act(obs, info) -> action`),
and their registry (`registry`: `AGENTS`, `make_agent`).

- `scripted`: the rule-based baseline (`scripted`, `scripted-shove`);
- `negotiated`: the whole board planned with rip-up and reroute, then laid (`negotiated`);
- `d1`: D1 boards planned on their lattice with rip-up and reroute (`d1`);
- `random`: masked random actions (`random`);
- `llm_agents`, `llm_client`: language models on any OpenAI-compatible server, in pcbdata's
  protocol (`llm`, `llm-plan`, `llm-direct`);
- `llm_paper`: the paper's LLM protocol (`llm-paper`, `llm-paper-plan`, `llm-paper-direct`);
- `llm_standin`: a scripted stand-in for a language model, for the LLM interface's tests.

The runners that play them are in `pcbdata.runners`.
"""

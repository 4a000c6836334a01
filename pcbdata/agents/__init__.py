"""Agents that route boards through the environment's actions (`act(obs, info) -> action`),
and the runners that play them.

- `scripted`: the rule-based baseline (`scripted`, `scripted-shove`);
- `d1`: D1 boards planned on their lattice with rip-up and reroute (`d1`);
- `random`: masked random actions (`random`);
- `llm_standin`: a scripted stand-in for a language model, for the LLM interface's tests;
- `rollout`: `pcbdata rollout` as a library (episodes in worker processes, RUNS written);
- `ray_actors`: environments as Ray actors, stepped from one driver.
"""

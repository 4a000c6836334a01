"""A learned router (docs/learn.md): a set policy over the RL wrapper's entity table
(`policy`), its batching (`batch`), behaviour cloning then PPO (`train`), the `policy` agent of
`pcbdata rollout` (`agent`). Needs the `train` extra (torch); nothing else of pcbdata imports it.
"""

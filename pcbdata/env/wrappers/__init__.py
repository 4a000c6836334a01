"""Gymnasium wrappers of the routing environment: the RL interface (`rl`, with the entity
table of `features`) and the run recorder (`recorder`)."""

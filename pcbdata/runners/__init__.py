"""The runners that play agents on board sets: `rollout` (`pcbdata rollout` as a library:
episodes in worker processes, RUNS written as `pcbdata eval` reads them), `ray_actors`
(environments as Ray actors, stepped from one driver) and `reference` (the reference routings
a D2R build asks for, one worker task per board). The agents themselves and their registry are
in `pcbdata.agents`."""

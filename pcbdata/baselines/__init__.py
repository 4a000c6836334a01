"""Baseline routers that route whole boards outside the environment (`pcbdata route`).

`specctra`: the Specctra round trip (KiCad exports DSN, a router writes SES, KiCad imports it);
`route`: `route_set` for every router. kicad-tools' worker code sits in the KiCad layer
(`pcbdata.kicad.kicad_tools_route`), beside the Specctra worker code, since only that layer
starts processes. Every router runs as a separate process: GPL routers are never imported.
"""

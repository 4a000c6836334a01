"""Baseline routers that route whole boards outside the environment (`pcbdata route`).

`specctra`: the Specctra round trip (KiCad exports DSN, a router writes SES, KiCad imports it).
Every router runs as a separate process: GPL routers are never imported.
"""

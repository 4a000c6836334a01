"""Baseline routing through a Specctra round trip (`pcbdata route`).

KiCad exports each instance as a Specctra DSN file, a router turns it into an SES session, and
KiCad imports the session and saves the routed board (`pcbdata.kicad.specctra`). The default
router is `freeroute` (pure Python, from PyPI: `pip install freeroute`); any command that reads
DSN and writes SES can be plugged in with `--router-cmd`, e.g.
`--router-cmd "java -jar freerouting.jar -de {dsn} -do {ses} -mp 20"`.

The freeroute work-arounds (SES resolution, back-side components, planning for vias, the
routing boundary) live in `pcbdata.kicad.specctra_text` and `pcbdata.kicad.specctra`; routing a set
is `pcbdata.baselines.route.route_set`.
"""
from __future__ import annotations

import shlex
import sys

from pcbdata.core.errors import UserError

ROUTE = "pcbdata.kicad.specctra:route_board"
#: freeroute options per rollout (cycled): rollout 0 is the package's most DRC-careful engine.
FREEROUTE_VARIANTS = (
    ("--engine", "exact", "--shove", "--diagonal"),
    ("--engine", "room", "--pack", "--shove"),
    ("--engine", "exact"),
    # Not `--engine grid`: it lets two nets' 45-degree segments cross inside one grid square.
    ("--engine", "exact", "--shove"),
    ("--engine", "exact", "--shove", "--diagonal", "-mp", "20"),
)


def freeroute_available() -> bool:
    """Whether freeroute is installed. It only ever runs as a separate process (`python -m
    freeroute.cli`), never imported into pcbdata (it is GPL-3.0-or-later, pcbdata is MIT)."""
    import importlib.util

    return importlib.util.find_spec("freeroute") is not None


def freeroute_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("freeroute")
    except PackageNotFoundError:
        return "unknown"


def router_command(router: str, router_cmd: str | None,
                   rollout: int) -> tuple[list[str], bool, str]:
    """(argv with {dsn}/{ses} placeholders, whether to apply the freeroute work-arounds, label)."""
    if router_cmd:
        argv = shlex.split(router_cmd)
        if "{dsn}" not in router_cmd or "{ses}" not in router_cmd:
            raise UserError("--router-cmd must contain {dsn} and {ses}, e.g. "
                            "'java -jar freerouting.jar -de {dsn} -do {ses}'")
        return argv, False, router_cmd
    if router != "freeroute":
        raise UserError(f"unknown router {router!r}; use --router freeroute or --router-cmd")
    if not freeroute_available():
        raise UserError("freeroute is not installed; run: pip install freeroute "
                        "(or give --router-cmd)")
    variant = list(FREEROUTE_VARIANTS[rollout % len(FREEROUTE_VARIANTS)])
    argv = [sys.executable, "-m", "freeroute.cli", "{dsn}", "-o", "{ses}", *variant]
    return argv, True, "freeroute " + " ".join(variant)

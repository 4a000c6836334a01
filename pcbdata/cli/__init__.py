"""The `pcbdata` command: one verb per job, one thin module per verb.

A verb module in this package defines `VERB` (its name), `HELP` (one line) and
`register(parser)` which adds its arguments and `parser.set_defaults(run=function)`;
`run(args)` returns the exit code. `build` has one module per family (`build_<family>.py`).
Verb modules are thin: they parse, call one library function and print its summary; the
errors of `pcbdata.core.errors` become one line and an exit code (2 bad input, 3 KiCad failure).
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from pcbdata import __version__
from pcbdata.core.errors import EngineError, PcbdataError, one_line
from pcbdata.kicad.pool import KicadError


def verb_modules(prefix: str = ""):
    """The verb modules (or, with `prefix="build_"`, the build families), discovered."""
    names = sorted(m.name for m in pkgutil.iter_modules(__path__))
    for name in names:
        if name.startswith("_") or (prefix and not name.startswith(prefix)):
            continue
        if not prefix and name.startswith("build_"):
            continue
        module = importlib.import_module(f"{__name__}.{name}")
        if hasattr(module, "register"):
            yield module


class _Parser(argparse.ArgumentParser):
    """Usage errors (a missing option, a value of the wrong type or range) are one line like
    every other bad input; subcommand parsers inherit this class."""

    def error(self, message: str):
        print(f"pcbdata: error: {self.prog}: {message} (see `{self.prog} --help`)",
              file=sys.stderr)
        sys.exit(2)


def make_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="pcbdata", description="Board sets, curation and scoring for PCBWorld-Bench.")
    parser.add_argument("--version", action="version", version=f"pcbdata {__version__}")
    verbs = parser.add_subparsers(dest="verb", metavar="VERB", required=True)
    for module in verb_modules():
        sub = verbs.add_parser(module.VERB, help=module.HELP, description=module.HELP)
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = make_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except PcbdataError as exc:
        print(f"pcbdata: {exc.label}: {exc.message()}", file=sys.stderr)
        return exc.exit_code
    except KicadError as exc:  # a pool task that failed; the pool names no board
        print(f"pcbdata: {EngineError.label}: {one_line(str(exc))}", file=sys.stderr)
        return EngineError.exit_code
    except OSError as exc:  # a full disk, a read-only folder, ...: not a bug of pcbdata
        from pcbdata.cli._checks import write_error_line

        line = write_error_line(exc, getattr(args, "out", None) or getattr(args, "root", None))
        if line is None:
            raise
        print(f"pcbdata: error: {line}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pcbdata: interrupted; run the same command again to resume", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())

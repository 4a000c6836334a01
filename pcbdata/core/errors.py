"""The errors of pcbdata: one base class, and per kind one exit code and one message line.

- `UserError`: bad input (parameters, names, files): `pcbdata: error: ...`, exit 2, nothing
  written. `GenerationError` is one: parameters a generator cannot realise.
- `ValidationError`: a generated board failed its check in KiCad: exit 1, the message lists the
  first failing boards with the violation and the parameters.
- `EngineError`: KiCad itself failed (could not start, crashed, timed out): exit 3, one line
  naming the board and the reason.

The CLI (`pcbdata.cli.main`) turns every `PcbdataError` into its line and exit code, never a
traceback. A leaf module: every layer may import it.
"""
from __future__ import annotations


def one_line(text: str) -> str:
    """`text` on one line (reasons from KiCad workers can span several)."""
    return " | ".join(line.strip() for line in str(text).splitlines() if line.strip())


class PcbdataError(Exception):
    """Base of every error pcbdata reports to the user."""

    exit_code = 1
    label = "error"

    def message(self) -> str:
        """What the CLI prints after `pcbdata: <label>: `."""
        return one_line(str(self))


class UserError(PcbdataError):
    """Bad input: parameters, names, files. The message names what and why."""

    exit_code = 2


class GenerationError(UserError):
    """A generator could not produce a board for the given parameters and seed."""


class ValidationError(PcbdataError):
    """A generated board failed its check in KiCad."""

    exit_code = 1
    label = "build failed"

    def message(self) -> str:
        return str(self)  # the first failing boards, one per line


class EngineError(PcbdataError):
    """KiCad (the engine) failed: could not start, crashed or exceeded its time limit.
    `board` names the board it failed on, when there is one."""

    exit_code = 3
    label = "KiCad failed"

    def __init__(self, reason: str, board: str | None = None):
        self.reason, self.board = reason, board
        super().__init__(f"{board}: {reason}" if board else reason)

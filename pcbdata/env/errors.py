"""The environment's errors: `pcbdata.core.errors` kinds that are also the built-in exceptions
Gymnasium users expect (`TypeError` for an unknown keyword, `ValueError` for a bad value)."""
from __future__ import annotations

from pcbdata.core.errors import EngineError, UserError


class EnvOptionError(UserError, TypeError):
    """An unknown keyword for `gym.make` (the message names the closest known one)."""


class EnvValueError(UserError, ValueError):
    """A bad option value or reset option (the message names the allowed ones)."""


class BoardLoadError(EnvValueError):
    """The instance's board cannot be loaded (or is larger than the observation's capacity)."""


class EngineFailure(EngineError, RuntimeError):
    """The KiCad worker crashed, timed out or raised: the episode cannot go on (`step` turns it
    into truncation with `info["engine_failure"]`; the next reset starts a fresh worker)."""

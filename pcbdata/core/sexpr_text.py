"""Finding s-expression blocks in Specctra/KiCad text without parsing the whole file."""
from __future__ import annotations

import re


def block_end(text: str, start: int) -> int:
    """Index just past the s-expression that opens at `text[start] == '('` (quotes respected)."""
    depth, quoted = 0, False
    for i in range(start, len(text)):
        c = text[i]
        if c == '"':
            quoted = not quoted
        elif not quoted and c == "(":
            depth += 1
        elif not quoted and c == ")":
            depth -= 1
            if depth == 0:
                return i + 1
    raise ValueError("unbalanced s-expression")


# A quoted string with KiCad's backslash escapes (\" and \\ do not end it).
_QUOTED = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
_OPEN, _CLOSE = ord("("), ord(")")


def cut_problem(data: bytes) -> str | None:
    """Why `data` is not one whole s-expression (a truncated or pasted-together board file),
    or None. Cheap (no parser): parentheses must balance outside quoted strings, and the file
    must end with the closing parenthesis of its first expression, whitespace aside.

    KiCad's parser does not always fail on such files: a board cut inside a pad's `(layers ...)`
    makes it spin until the worker's time limit, so files are checked before KiCad sees them.
    """
    import numpy as np

    unquoted = _QUOTED.sub(b"", data)
    if b'"' in unquoted:
        return "truncated or malformed file: a quoted string is not closed"
    bare = np.frombuffer(unquoted, dtype=np.uint8)
    where = np.flatnonzero((bare == _OPEN) | (bare == _CLOSE))
    if where.size == 0:
        return "not an s-expression (no parentheses)"
    depth = np.cumsum(np.where(bare[where] == _OPEN, 1, -1))
    if depth[-1] > 0:
        return (f"truncated or malformed file: {int(depth[-1])} parentheses are not closed "
                f"at the end")
    if depth.min() < 0:
        return "malformed file: a ')' closes nothing"
    if depth[:-1].min(initial=1) == 0 or unquoted[int(where[-1]) + 1:].strip():
        return "malformed file: text after the end of the board's expression"
    return None

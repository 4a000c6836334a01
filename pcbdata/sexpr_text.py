"""Finding s-expression blocks in Specctra/KiCad text without parsing the whole file."""
from __future__ import annotations


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

"""Canonical text formats written by pcbdata: the one home of them. A leaf module (stdlib only).

- `canonical_json`: sorted keys, UTF-8 text (no ASCII escapes), a final newline; indent 1 for
  pcbdata's own files (manifests, states, reports), 2 for KiCad project files (KiCad's layout).
- `csv_text`: a header and one line per row, `\\n` line ends, columns in the given order.

The same data always gives the same bytes: manifests and board files are hashed and pinned.
"""
from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable, Mapping
from typing import Any


def canonical_json(data: Any, indent: int = 1) -> str:
    return json.dumps(data, indent=indent, sort_keys=True, ensure_ascii=False) + "\n"


def csv_text(rows: Iterable[Mapping[str, Any]], columns: list[str]) -> str:
    """CSV of `rows` (keys outside `columns` are ignored, missing ones left empty)."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n",
                            extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow(row)
    return buffer.getvalue()

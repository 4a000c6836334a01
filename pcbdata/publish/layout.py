"""Where the published parts of a board set live, and the names shared by writer and readers.

A published set is the built tree plus:

    README.md                                    the dataset card (written last: the commit point)
    publish.json                                 what was published: per config a fingerprint of
                                                 its manifest entry, shard names, sizes and hashes
    ATTRIBUTION.md                               per-board source and licence (sets with D3 only)
    <config>/<split>-NNNNN-of-NNNNN.parquet      the rows
    pictures/<config>/pads.svg, pictures/<config>/<board_id>.svg, pictures/d3-tiers-pads.svg
    pictures/<config>/beside-d3-<tier>.svg       D2R: a board beside a real board of its tier

A set whose card is missing is not published (or was being re-published when it was stopped):
`load` refuses it with a clear message and `verify` reports it.
"""
from __future__ import annotations

import difflib
import os
import re
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import write_atomic
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, REFERENCE_FILE, RULES_FILE
from pcbdata.sets.configs import order_key

CARD_NAME = "README.md"
STATE_NAME = "publish.json"
ATTRIBUTION_NAME = "ATTRIBUTION.md"
PICTURES_DIR = "pictures"
STAGE_NAME = ".pcbdata-publish.tmp"  # removed by fsutil.remove_stale_temps if a run is killed
LOCK_NAME = ".pcbdata-publish.lock"
PUBLISH_FORMAT = "pcbdata-publish/1"
INTERRUPTED_KEY = "pcbdata_publishing_interrupted"  # in the stub card written during a commit

SPLIT_ORDER = ("train", "validation", "test", "full")
SHARD_RE = re.compile(r"^(?P<split>[A-Za-z0-9_]+)-(?P<index>\d{5})-of-(?P<total>\d{5})\.parquet$")

# Board-folder file -> (text column, hash column). Every other file of a board folder goes to
# the `other_files` column, so that any tree round-trips.
FILE_COLUMNS = {
    BOARD_FILE: ("board", "sha256"),
    PROJECT_FILE: ("project", "project_sha256"),
    RULES_FILE: ("custom_rules", "custom_rules_sha256"),
    REFERENCE_FILE: ("reference", "reference_sha256"),
}
TEXT_COLUMNS = tuple(text for text, _ in FILE_COLUMNS.values())


def shard_name(split: str, index: int, total: int) -> str:
    return f"{split}-{index:05d}-of-{total:05d}.parquet"


def split_key(split: str) -> tuple[int, str]:
    return (SPLIT_ORDER.index(split) if split in SPLIT_ORDER else len(SPLIT_ORDER), split)


def config_key(config: str) -> tuple:
    """Reading order of configs (`pcbdata.sets.configs.order_key`): d2 (and its levels), d1 by grid
    size, d3 tiers, then the rest."""
    return order_key(config)


def default_config(configs) -> str:
    """The config marked `default: true`: the benchmark's D2 when present."""
    return sorted(configs, key=config_key)[0]


def suggest(name: str, choices, what: str) -> UserError:
    """A one-line error for an unknown name, with the nearest known one."""
    choices = sorted(choices, key=config_key if what == "config" else split_key)
    close = difflib.get_close_matches(name, choices, n=1, cutoff=0.5)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return UserError(f"unknown {what} {name!r}{hint} ({what}s: {', '.join(choices) or 'none'})")


def write_file(path: str | Path, data: str | bytes) -> None:
    """Atomic write of a published file, readable by everyone (like the shards)."""
    write_atomic(path, data)
    os.chmod(path, 0o644)


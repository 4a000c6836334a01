"""`verify_published`: the parquet rows of a published set against its manifest."""
from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

import pyarrow.parquet as pq

from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import sha256_bytes, sha256_file
from pcbdata.publish.card import read_card_configs
from pcbdata.publish.layout import CARD_NAME, FILE_COLUMNS, STATE_NAME, config_key, split_key
from pcbdata.publish.rows import is_redistributable

_READ_COLUMNS = ["board_id", "split", "redistributable", "other_files",
                 *(c for pair in FILE_COLUMNS.values() for c in pair)]


def recorded_shard_hashes(root: Path) -> dict[str, str]:
    """Shard path -> sha256 as `publish.json` recorded them (empty without it, e.g. a Hub copy)."""
    try:
        state = json.loads((root / STATE_NAME).read_text(encoding="utf-8"))
        return {rel: info["sha256"] for cfg in state.get("configs", {}).values()
                for split in cfg.get("splits", {}).values()
                for rel, info in split.get("shards", {}).items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


def recorded_pictures(root: Path) -> set[str] | None:
    """Picture paths `publish.json` recorded (per config and set-wide); None without it."""
    try:
        state = json.loads((root / STATE_NAME).read_text(encoding="utf-8"))
        per_config = {rel for cfg in state.get("configs", {}).values()
                      for rel in cfg.get("pictures", [])}
        return per_config | set(state.get("pictures", []))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def verify_published(root: str | Path, manifest: dict) -> list[str]:
    """Problems of the published rows versus `manifest`: missing card, unpublished or unknown
    configs and splits, missing or corrupt shards, and every missing, extra, duplicated or
    altered board. An empty list means the rows match the manifest exactly."""
    root = Path(root)
    if not (root / CARD_NAME).is_file():
        return [f"{CARD_NAME}: missing dataset card: the set is not published (or publishing was "
                f"interrupted); run `pcbdata publish {root}`"]
    try:
        card = read_card_configs(root)
    except UserError as exc:
        return [str(exc)]
    problems: list[str] = []
    known_hashes = recorded_shard_hashes(root)
    configs = manifest.get("configs", {})
    for config in sorted(set(card) - set(configs), key=config_key):
        problems.append(f"{config}: listed in the card but not in the manifest")
    for config in sorted(configs, key=config_key):
        if config not in card:
            problems.append(f"{config}: in the manifest but not published (not in the card)")
            continue
        m_splits = configs[config].get("splits", {})
        for split in sorted(set(card[config]) - set(m_splits), key=split_key):
            problems.append(f"{config}/{split}: split in the card but not in the manifest")
        for split in sorted(m_splits, key=split_key):
            if split not in card[config]:
                problems.append(f"{config}/{split}: split in the manifest but not published")
                continue
            problems += _verify_split(root, config, split, m_splits[split].get("boards", {}),
                                      card[config][split], known_hashes)
    return problems


def _verify_split(root: Path, config: str, split: str, boards: dict, shards: list[str],
                  known_hashes: dict[str, str]) -> list[str]:
    problems = []
    where = f"{config}/{split}"
    seen: Counter = Counter()
    damaged = False
    for rel in shards:
        path = root / rel
        if not path.is_file():
            problems.append(f"{rel}: shard missing")
            damaged = True
            continue
        if rel in known_hashes and sha256_file(path) != known_hashes[rel]:
            problems.append(f"{rel}: shard altered or corrupt (sha256 differs from {STATE_NAME})")
            damaged = True
            continue
        try:
            table = pq.read_table(path, columns=_READ_COLUMNS)
        except Exception as exc:  # noqa: BLE001 - any reader failure means a damaged shard
            first_line = str(exc).splitlines()[0] if str(exc) else ""
            problems.append(f"{rel}: corrupt shard ({type(exc).__name__}: {first_line})")
            damaged = True
            continue
        for row in table.to_pylist():
            board_id = row["board_id"]
            seen[board_id] += 1
            if row["split"] != split:
                problems.append(f"{where}/{board_id}: row says split {row['split']!r}")
            entry = boards.get(board_id)
            if entry is None:
                continue
            problems += _check_row(where, board_id, row, entry)
    missing = sorted(set(boards) - set(seen))
    if damaged and missing:
        problems.append(f"{where}: {len(missing)} boards of the manifest not found in the "
                        f"readable shards (see the damaged shard above)")
        missing = []
    for board_id in missing:
        problems.append(f"{where}/{board_id}: missing from the parquet rows")
    for board_id in sorted(set(seen) - set(boards)):
        problems.append(f"{where}/{board_id}: extra row, not in the manifest")
    for board_id, count in sorted(seen.items()):
        if count > 1:
            problems.append(f"{where}/{board_id}: {count} rows")
    return problems


def _check_row(where: str, board_id: str, row: dict, entry: dict,
               against: str = "the manifest") -> list[str]:
    """One row's files (hashes, and texts unless a recipe row) against a board `entry` of the
    manifest (or, `against` "the pinned release", of a release manifest)."""
    problems = []
    files = dict(entry.get("files", {}))
    recipe = not is_redistributable(entry)
    present = {}
    for name, (text_col, hash_col) in FILE_COLUMNS.items():
        if row.get(hash_col) is not None or row.get(text_col) is not None:
            present[name] = (row.get(text_col), row.get(hash_col))
    for item in row.get("other_files") or []:
        present[item["name"]] = (item["text"], item["sha256"])
    for name in sorted(set(files) | set(present)):
        if name not in present:
            problems.append(f"{where}/{board_id}: {name} missing from its row")
            continue
        if name not in files:
            problems.append(f"{where}/{board_id}: row has {name}, which {against} does not list")
            continue
        text, digest = present[name]
        if digest != files[name]:
            problems.append(
                f"{where}/{board_id}: {name} altered (row sha256 differs from {against})")
        elif recipe:
            if text is not None:
                problems.append(f"{where}/{board_id}: recipe row (not redistributable) carries "
                                f"the text of {name}")
        elif text is None:
            problems.append(f"{where}/{board_id}: {name} text missing from its row")
        elif sha256_bytes(text.encode("utf-8")) != files[name]:
            problems.append(f"{where}/{board_id}: {name} altered (text does not match its sha256)")
    if bool(row.get("redistributable", True)) == recipe:
        problems.append(f"{where}/{board_id}: redistributable flag differs from {against}")
    return problems


def release_row_problems(rows: Iterable[dict], release, split: str,
                         expected: set[str] | None = None) -> list[str]:
    """Loaded rows of one split against a `PinnedRelease`: every row is a board of the release
    split with the same files (hashes, and texts that match them), the release's set version
    and parameters, and the rows hold exactly `expected` board ids (default: the whole release
    split; a set whose manifest declares a subset passes its own board ids)."""
    where = f"{release.config}/{split}"
    released = release.entry["splits"].get(split)
    if released is None:
        return [f"{where}: split not in the pinned release"]
    boards = released.get("boards", {})
    expected = set(boards) if expected is None else expected
    against = "the pinned release"
    problems: list[str] = []
    seen: Counter[str] = Counter()
    versions: set = set()
    parameters: set = set()
    for row in rows:
        board_id = row["board_id"]
        seen[board_id] += 1
        versions.add(row.get("set_version"))
        parameters.add(row.get("parameters"))
        if board_id not in boards:
            problems.append(f"{where}/{board_id}: not in the pinned release")
        else:
            problems += _check_row(where, board_id, row, boards[board_id], against)
    problems += _release_identity(where, release, versions, parameters)
    for board_id in sorted(expected - set(seen)):
        source = "in the pinned release" if board_id in boards else "listed in the set's manifest"
        problems.append(f"{where}/{board_id}: {source} but not in the rows")
    for board_id in sorted((set(seen) & set(boards)) - expected):
        problems.append(f"{where}/{board_id}: row not in the set's manifest")
    problems += [f"{where}/{board_id}: {count} rows"
                 for board_id, count in sorted(seen.items()) if count > 1]
    return problems


def _release_identity(where: str, release, versions: set, parameters: set) -> list[str]:
    """The set version and parameters (or recipe) columns, once per split, not once per row."""
    problems = []
    wanted = release.entry.get("parameters", release.entry.get("recipe"))
    for version in sorted((v for v in versions if v != release.version), key=str):
        problems.append(f"{where}: rows say set_version {version!r}, "
                        f"the release is {release.version!r}")
    if any(_json_or_none(text) != wanted for text in parameters):
        problems.append(f"{where}: rows carry other parameters than the pinned release")
    return problems


def _json_or_none(text: str | None):
    try:
        return json.loads(text) if text is not None else None
    except ValueError:
        return None  # unreadable parameters are "other parameters", not a crash

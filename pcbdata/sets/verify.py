"""Verification of a built board set (`pcbdata verify DIR [--release]`).

Checks a built board set against its manifest: every file's sha256, nothing missing, nothing
extra (at any level: top, config, split and board folders), no leftovers of an interrupted run,
and (when published) the parquet rows and card. `verify_release` compares the manifest itself
with the release pinned in the package (`pcbdata verify DIR --release`)."""
from __future__ import annotations

from pathlib import Path

from pcbdata.core.tree import D3_STATE_DIR, SYNTHETIC_STATE_DIR
from pcbdata.model.manifest import MANIFEST_NAME, read_manifest
from pcbdata.sets.boards import check_file, check_split, is_leftover

# A `hf download --local-dir` of a set adds its metadata folder and the Hub repo's attributes.
HUB_DOWNLOAD_ENTRIES = (".cache", ".gitattributes")


def verify_set(root: str | Path) -> list[str]:
    """Problems found, one line each, naming the board and file; empty when the set is intact."""
    root = Path(root)
    manifest = read_manifest(root)
    problems: list[str] = []
    shards = _published_shards(root)
    for config_name, config in sorted(manifest["configs"].items()):
        problems += _check_config(root / config_name, config_name, config, shards)
    problems += _unlisted_top_entries(root, manifest)
    problems += _unlisted_pictures(root)
    problems += _published_problems(root, manifest)
    return problems


def verify_release(root: str | Path, configs: list[str] | None = None):
    """The set's manifest against the releases pinned in the package: one `ReleaseCheck` per
    config (its `problems`, and `line()` naming the pinned file it was compared with)."""
    from pcbdata.sets.releases import check_release

    return check_release(read_manifest(root), configs)


def allowed_top_entries() -> set[str]:
    """Top-level names a set may hold besides `manifest.json` and its config folders: the
    published parts, the D3 build's tables, the builds' resume state and a Hub download's
    metadata. Leftovers of interrupted runs (`.*.tmp`) are reported separately."""
    from pcbdata.publish.layout import (
        ATTRIBUTION_NAME,
        CARD_NAME,
        LOCK_NAME,
        PICTURES_DIR,
        STATE_NAME,
    )
    from pcbdata.publish.push import EXTRA_TOP_FILES

    return {MANIFEST_NAME, CARD_NAME, STATE_NAME, ATTRIBUTION_NAME, PICTURES_DIR, LOCK_NAME,
            SYNTHETIC_STATE_DIR, D3_STATE_DIR, *EXTRA_TOP_FILES, *HUB_DOWNLOAD_ENTRIES}


def _check_config(config_dir: Path, config_name: str, config: dict, shards: set[str]) -> list[str]:
    problems: list[str] = []
    known = set(config["splits"])
    for split_name, split in sorted(config["splits"].items()):
        where = f"{config_name}/{split_name}"
        known.update(split.get("arrays", {}))
        for array_name, sha in split.get("arrays", {}).items():
            problems += check_file(config_dir / array_name, sha, f"{config_name}/{array_name}")
        if split.get("count", len(split["boards"])) != len(split["boards"]):
            problems.append(f"{where}: count says {split['count']} boards but the manifest "
                            f"lists {len(split['boards'])}")
        pending = _references_pending(split)
        if pending:
            problems.append(f"{where}: reference routing unfinished: {pending} of "
                            f"{len(split['boards'])} boards have no result yet (the build "
                            f"stopped before its end; run it again, it resumes)")
        problems += check_split(config_dir / split_name, where, split["boards"],
                                references_pending=bool(pending))
    if config_dir.is_dir():
        for entry in sorted(config_dir.iterdir()):
            rel = f"{config_name}/{entry.name}"
            if is_leftover(entry.name):
                problems.append(f"{rel}: leftover of an interrupted run")
            elif entry.name in known or rel in shards:
                continue
            elif entry.is_dir():
                problems.append(f"{rel}: split folder not in the manifest "
                                f"({_count(entry)} entries unlisted)")
            else:
                is_shard = rel.endswith(".parquet")
                problems.append(f"{rel}: extra file not in the manifest"
                                + (" (a shard the card does not list)" if is_shard else ""))
    return problems


def _references_pending(split: dict) -> int:
    """Boards of a split routed for references that have no result yet: the manifest written
    before the routing, left by a build stopped during it."""
    record = split.get("reference_routing")
    return max(0, len(split["boards"]) - record["boards"]) if record else 0


def _count(folder: Path) -> int:
    return sum(1 for _ in folder.iterdir())


def _unlisted_top_entries(root: Path, manifest: dict) -> list[str]:
    """Top-level entries that are neither configs of the manifest nor a known part of a set,
    e.g. the config folder of a concurrent build whose manifest entry was overwritten."""
    allowed = allowed_top_entries() | set(manifest["configs"])
    problems = []
    for entry in sorted(root.iterdir()):
        if entry.name in allowed or is_leftover(entry.name):
            continue  # leftovers: `_published_problems` names them
        if entry.is_dir():
            problems.append(f"{entry.name}: config folder not in the manifest "
                            f"({_count(entry)} entries unlisted)")
        else:
            problems.append(f"{entry.name}: extra file not in the manifest")
    return problems


def _published_shards(root: Path) -> set[str]:
    """Shards the publication lists (publish.json and the card): the other files of a config
    folder that are not in the manifest."""
    from pcbdata.core.errors import UserError
    from pcbdata.publish.audit import recorded_shard_hashes
    from pcbdata.publish.card import read_card_configs
    from pcbdata.publish.layout import CARD_NAME

    shards = set(recorded_shard_hashes(root))
    if (root / CARD_NAME).is_file():
        try:
            card = read_card_configs(root)
        except UserError:
            return shards  # a stub or broken card: `verify_published` reports it
        shards.update(rel for splits in card.values() for paths in splits.values() for rel in paths)
    return shards


def _unlisted_pictures(root: Path) -> list[str]:
    from pcbdata.publish.audit import recorded_pictures
    from pcbdata.publish.layout import PICTURES_DIR

    folder = root / PICTURES_DIR
    recorded = recorded_pictures(root)
    if not folder.is_dir() or recorded is None:
        return []
    on_disk = {str(p.relative_to(root)) for p in folder.rglob("*") if p.is_file()}
    return [f"{rel}: extra file not listed in publish.json" for rel in sorted(on_disk - recorded)]


def _published_problems(root: Path, manifest: dict) -> list[str]:
    from pcbdata.publish import verify_published

    problems = [f"{p.name}: leftover of an interrupted publish"
                for p in sorted(root.glob(".*.tmp"))]
    if (root / "README.md").exists() or (root / "publish.json").exists():
        problems += verify_published(root, manifest)
    return problems

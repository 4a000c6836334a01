"""What a report scored: the set's identity and whether its boards are the ones it claims.

A set edited together with its manifest passes a plain `verify`, so a report records the set's
config, version and manifest sha256, the outcome of checking the scored split's boards against
the manifest, and whether the config matches the release pinned in pcbdata (`verify
--release`). Scoring boards that fail the manifest check is refused unless asked for, and then
marked in the report.
"""
from __future__ import annotations

from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_file
from pcbdata.model.manifest import manifest_path, read_manifest
from pcbdata.sets.boards import check_split

#: Problems quoted in a report or an error (all are counted).
SHOWN_PROBLEMS = 5


def scored_split_problems(root: Path, manifest: dict, config: str, split: str) -> list[str]:
    """`pcbdata verify`'s checks of one split's boards: every file the manifest lists, with its
    sha256, and nothing else in the board folders."""
    entry = manifest.get("configs", {}).get(config)
    if entry is None or split not in entry.get("splits", {}):
        return [f"{config}/{split}: not in the set's manifest"]
    return check_split(root / config / split, f"{config}/{split}",
                       entry["splits"][split]["boards"])


def release_status(manifest: dict, config: str, split: str) -> tuple[str, list[str]]:
    """("matches" | "differs" | "not released", problems) of the config's scored split against
    the release pinned in pcbdata."""
    from pcbdata.sets.releases import check_release

    check = check_release(manifest, [config], [split])[0]
    if check.release is None:
        return "not released", []
    return ("differs" if check.problems else "matches"), check.problems


def set_identity(root: str | Path, config: str, split: str) -> dict:
    """The `set` block of a report: config, split, set version, manifest sha256, `verified`
    (the scored boards match the manifest) with the first problems, and `release`."""
    root = Path(root)
    try:
        manifest = read_manifest(root)
    except UserError as exc:  # no manifest, or not one pcbdata can read
        return {"config": config, "split": split, "set_version": None, "manifest_sha256": None,
                "verified": False, "problems": [str(exc)], "n_problems": 1,
                "release": "not checked", "release_problems": []}
    entry = manifest.get("configs", {}).get(config, {})
    problems = scored_split_problems(root, manifest, config, split)
    release, release_problems = release_status(manifest, config, split) if not problems \
        else ("not checked", [])
    return {"config": config, "split": split, "set_version": entry.get("set_version"),
            "manifest_sha256": sha256_file(manifest_path(root)), "verified": not problems,
            "problems": problems[:SHOWN_PROBLEMS], "n_problems": len(problems),
            "release": release, "release_problems": release_problems[:SHOWN_PROBLEMS]}


def refuse_unverified(identity: dict, root: str | Path) -> None:
    """Raises when the scored boards do not match the set's manifest."""
    if identity["verified"]:
        return
    shown = "; ".join(identity["problems"])
    raise UserError(f"{root}: {identity['n_problems']} problem(s) with the boards of "
                    f"{identity['config']}/{identity['split']} against the set's manifest "
                    f"({shown}); `pcbdata verify {root}` lists them. Score it anyway with "
                    f"--allow-unverified (the report then says so)")


def mark(identity: dict | None) -> str:
    """A note for the method's cell of the table: empty for a verified set. (A set that differs
    from its release, e.g. built with another seed, is named so in the report's set line.)"""
    if identity is None or identity["verified"]:
        return ""
    return " (unverified set)"

"""The manifests of released sets, shipped in the package under `pcbdata/resources/releases/`.

One file per config, `pcbdata/resources/releases/<config>.json.gz` (gzip without timestamp, so
the bytes depend only on the content): the manifest of the released build restricted to that
config, with every board's sha256; an earlier set version stays as
`<config>@<version>.json.gz`. A test rebuilds the small splits (validation, test) and
compares them with these files, so a change that alters boards cannot land unnoticed.

`check_release(manifest)` compares a set's own manifest with these pinned releases
(`pcbdata verify DIR --release`, `pcbdata.load(..., release=True)`): a set whose manifest was
edited together with its boards still verifies against itself, but not against the pin.

    python -m pcbdata.sets.releases export DIR [--configs d2,d1-g10] [--out manifests]
    python -m pcbdata.sets.releases check DIR  [--dir manifests]   # DIR: a (partial) rebuild
"""
from __future__ import annotations

import argparse
import gzip
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import write_atomic
from pcbdata.model.manifest import read_manifest
from pcbdata.resources import resource_path

SUFFIX = ".json.gz"
#: An earlier release of a config stays pinned as `<config>@<set version>.json.gz`, so a set
#: rebuilt with an older recipe (`pcbdata build d3 --recipe d3-1.0.0`) still verifies.
VERSION_MARK = "@"
# Config fields that may differ between a release and a partial rebuild of it.
_VOLATILE = {"splits"}
_SPLIT_VOLATILE = {"kicad_checked"}


def release_bytes(manifest: dict, config: str) -> bytes:
    entry = {k: manifest[k] for k in ("format", "package_version", "kicad_version")
             if k in manifest}
    entry["configs"] = {config: manifest["configs"][config]}
    text = json.dumps(entry, indent=1, sort_keys=True, ensure_ascii=False) + "\n"
    return gzip.compress(text.encode("utf-8"), compresslevel=9, mtime=0)


def export(root: str | Path, out_dir: str | Path, configs: list[str] | None = None) -> list[Path]:
    manifest = read_manifest(root)
    written = []
    for config in configs or sorted(manifest["configs"]):
        if config not in manifest["configs"]:
            raise UserError(f"{root}: no config {config!r} in the manifest")
        path = Path(out_dir) / f"{config}{SUFFIX}"
        write_atomic(path, release_bytes(manifest, config))
        written.append(path)
    return written


def read_release(path: str | Path) -> dict:
    with gzip.open(path, "rt", encoding="utf-8") as handle:
        return json.load(handle)


def released_configs() -> list[str]:
    """Configs with a pinned release in this package (their current versions)."""
    from pcbdata.sets.configs import order_key

    folder = resource_path("releases")
    return sorted((p.name[: -len(SUFFIX)] for p in folder.iterdir()
                   if p.name.endswith(SUFFIX) and VERSION_MARK not in p.name), key=order_key)


@dataclass
class PinnedRelease:
    config: str
    source: str  # the packaged file, named in every report so the reader knows what was compared
    manifest: dict

    @property
    def entry(self) -> dict:
        return self.manifest["configs"][self.config]

    @property
    def version(self) -> str:
        return str(self.entry.get("set_version"))

    def describe(self) -> str:
        return f"release {self.config} {self.version} ({self.source})"


def pinned_release(config: str, version: str | None = None) -> PinnedRelease | None:
    """The pinned release of `config`: of its set `version` where an earlier release of that
    version is pinned, else the current one (None if the config has none)."""
    path = resource_path("releases", f"{config}{VERSION_MARK}{version}{SUFFIX}")
    if version is None or not path.is_file():
        path = resource_path("releases", f"{config}{SUFFIX}")
    if not path.is_file():
        return None
    # read through the resource API: the package may live in a zip, not as plain files
    manifest = json.loads(gzip.decompress(path.read_bytes()).decode("utf-8"))
    return PinnedRelease(config, str(path), manifest)


@dataclass
class ReleaseCheck:
    """One config of a set compared with its pinned release."""

    config: str
    release: PinnedRelease | None
    problems: list[str] = field(default_factory=list)
    compared: list[tuple[str, int, int]] = field(default_factory=list)  # (split, held, released)
    absent: list[str] = field(default_factory=list)  # release splits the set does not hold

    @property
    def subset(self) -> bool:
        return bool(self.absent) or any(held < released for _, held, released in self.compared)

    def line(self) -> str:
        """One line saying what was compared with which pinned file, and the outcome."""
        if self.release is None:
            return f"{self.config}: no pinned release"
        status = "matches" if not self.problems else f"{len(self.problems)} difference(s)"
        kind = "subset of the release" if self.subset else "whole release"
        splits = ", ".join(f"{split} {held} of {released} boards"
                           for split, held, released in self.compared) or "no splits"
        absent = f"; not in this set: {', '.join(self.absent)}" if self.absent else ""
        return f"{self.release.describe()}: {status} ({kind}: {splits}{absent})"


def check_release(manifest: dict, configs: list[str] | None = None,
                  splits: list[str] | None = None) -> list[ReleaseCheck]:
    """Each config of `manifest` (or of `configs`) against its pinned release.

    Subsets pass: a split the set does not hold is listed in `absent`, and a split whose `count`
    is below the release's (a `--count` build) must hold only boards of the release, each
    identical. A split that claims the release's count must hold exactly its boards (and the
    same arrays). Every config-level field (set version, parameters or recipe, seed, ...) must
    equal the release's; `kicad_checked` may differ (a build with `--no-check` holds the same
    boards). A config without a pinned release is a problem: it cannot be the released set."""
    checks = []
    for config in configs or sorted(manifest.get("configs", {})):
        entry = manifest.get("configs", {}).get(config)
        if entry is None:
            raise UserError(f"no config {config!r} in the set's manifest")
        release = pinned_release(config, str(entry.get("set_version")))
        check = ReleaseCheck(config, release)
        if release is None:
            check.problems.append(
                f"{config}: no pinned release of this config in pcbdata (pinned: "
                f"{', '.join(released_configs())}); it cannot be checked with --release")
        else:
            _check_config(check, release, entry, splits)
        checks.append(check)
    return checks


def _check_config(check: ReleaseCheck, release: PinnedRelease, entry: dict,
                  splits: list[str] | None) -> None:
    config, pinned = check.config, release.entry
    for key in sorted((set(pinned) | set(entry)) - _VOLATILE):
        for path, old, new in _differences(key, pinned.get(key), entry.get(key)):
            check.problems.append(
                f"{config}: {path} is {_short(new)}, the release has {_short(old)}")
    wanted = splits or sorted(entry.get("splits", {}))
    check.absent = [s for s in sorted(pinned["splits"]) if s not in wanted]
    for split in wanted:
        if split not in pinned["splits"]:
            check.problems.append(f"{config}/{split}: split not in the pinned release (release "
                                  f"splits: {', '.join(sorted(pinned['splits']))})")
        elif split not in entry.get("splits", {}):
            raise UserError(f"no split {config}/{split} in the set's manifest")
        else:
            check.problems += _check_split(f"{config}/{split}", pinned["splits"][split],
                                           entry["splits"][split])
            check.compared.append((split, entry["splits"][split].get("count", 0),
                                   pinned["splits"][split].get("count", 0)))


def _check_split(where: str, pinned: dict, split: dict) -> list[str]:
    count, full = split.get("count", 0), pinned.get("count", 0)
    if count > full:
        return [f"{where}: {count} boards, the pinned release has {full}"]
    problems = []
    whole = count == full  # a split that claims the release's size must be the release's split
    if whole:
        for key in sorted((set(pinned) | set(split)) - _SPLIT_VOLATILE - {"boards", "count"}):
            for path, _old, _new in _differences(key, pinned.get(key), split.get(key)):
                problems.append(f"{where}: {path} differs from the pinned release")
    released, held = pinned.get("boards", {}), split.get("boards", {})
    for board_id in sorted(set(held) | (set(released) if whole else set())):
        if board_id not in released:
            problems.append(f"{where}/{board_id}: not in the pinned release")
        elif board_id not in held:
            problems.append(f"{where}/{board_id}: in the pinned release but not in the set "
                            f"(its split claims all {full} boards)")
        elif held[board_id] != released[board_id]:
            problems.append(f"{where}/{board_id}: differs from the pinned release "
                            f"({', '.join(changed_fields(released[board_id], held[board_id]))})")
    return problems


def changed_fields(old: dict, new: dict) -> list[str]:
    """What differs between two board entries: file names first, then facts."""
    files_old, files_new = old.get("files", {}), new.get("files", {})
    files = [n for n in sorted(set(files_old) | set(files_new))
             if files_old.get(n) != files_new.get(n)]
    facts = [k for k in sorted((set(old) | set(new)) - {"files"}) if old.get(k) != new.get(k)]
    return files + facts


def _differences(path: str, old, new, depth: int = 2):
    """(dotted path, old, new) of each differing leaf, looking `depth` dict levels deep, so a
    changed parameter is named rather than the whole parameter table printed."""
    if old == new:
        return
    if depth and isinstance(old, dict) and isinstance(new, dict):
        for key in sorted(set(old) | set(new)):
            yield from _differences(f"{path}.{key}", old.get(key), new.get(key), depth - 1)
    else:
        yield path, old, new


def _short(value, limit: int = 80) -> str:
    text = "(absent)" if value is None else repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def compare(release: dict, rebuilt: dict, config: str,
            splits: list[str] | None = None) -> list[str]:
    """Differences between a released config and a rebuild of some of its splits."""
    problems = []
    old = release["configs"][config]
    new = rebuilt.get("configs", {}).get(config)
    if new is None:
        return [f"{config}: not in the rebuilt manifest"]
    for key in sorted((set(old) | set(new)) - _VOLATILE):
        if old.get(key) != new.get(key):
            problems.append(f"{config}: {key} changed: {old.get(key)!r} -> {new.get(key)!r}")
    for split in splits or sorted(new.get("splits", {})):
        a, b = old["splits"].get(split), new["splits"].get(split)
        if a is None or b is None:
            side = "release" if a is None else "rebuild"
            problems.append(f"{config}/{split}: split missing from the {side}")
            continue
        for key in sorted((set(a) | set(b)) - _SPLIT_VOLATILE - {"boards"}):
            if a.get(key) != b.get(key):
                problems.append(
                    f"{config}/{split}: {key} changed: {a.get(key)!r} -> {b.get(key)!r}")
        boards_a, boards_b = a.get("boards", {}), b.get("boards", {})
        for board_id in sorted(set(boards_a) | set(boards_b)):
            if board_id not in boards_b:
                problems.append(f"{config}/{split}/{board_id}: missing from the rebuild")
            elif board_id not in boards_a:
                problems.append(f"{config}/{split}/{board_id}: not in the release")
            elif boards_a[board_id] != boards_b[board_id]:
                what = changed_fields(boards_a[board_id], boards_b[board_id])
                problems.append(f"{config}/{split}/{board_id}: changed ({', '.join(what)})")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pcbdata.sets.releases")
    verbs = parser.add_subparsers(dest="verb", required=True)
    ex = verbs.add_parser(
        "export",
        help="write pcbdata/resources/releases/<config>.json.gz from a released build")
    ex.add_argument("root")
    ex.add_argument("--configs", default=None)
    ex.add_argument("--out", default="pcbdata/resources/releases")
    ch = verbs.add_parser("check", help="compare a rebuild with the committed manifests")
    ch.add_argument("root")
    ch.add_argument("--dir", default="pcbdata/resources/releases")
    args = parser.parse_args(argv)
    try:
        if args.verb == "export":
            configs = args.configs.split(",") if args.configs else None
            for path in export(args.root, args.out, configs):
                print(path)
            return 0
        rebuilt = read_manifest(args.root)
        problems = []
        for config in sorted(rebuilt["configs"]):
            path = Path(args.dir) / f"{config}{SUFFIX}"
            if path.is_file():
                problems += compare(read_release(path), rebuilt, config)
        print("\n".join(problems) or "rebuild matches the committed manifests")
        return 1 if problems else 0
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

"""The manifests of released sets, shipped in the package under `pcbdata/resources/releases/`.

One file per config, `pcbdata/resources/releases/<config>.json.gz` (gzip without timestamp, so the bytes depend
only on the content): the manifest of the released build restricted to that config, with every
board's sha256. A test rebuilds the small splits (validation, test) and compares them with these
files, so a change that alters boards cannot land unnoticed.

    python -m pcbdata.publish.manifests export DIR [--configs d2,d1-g10] [--out manifests]
    python -m pcbdata.publish.manifests check DIR  [--dir manifests]   # DIR: a (partial) rebuild
"""
from __future__ import annotations

import argparse
import gzip
import json
import sys
from pathlib import Path

from pcbdata.errors import UserError
from pcbdata.fsutil import write_atomic
from pcbdata.manifest import read_manifest

SUFFIX = ".json.gz"
# Config fields that may differ between a release and a partial rebuild of it.
_VOLATILE = {"splits"}
_SPLIT_VOLATILE = {"kicad_checked"}


def release_bytes(manifest: dict, config: str) -> bytes:
    entry = {k: manifest[k] for k in ("format", "package_version", "kicad_version") if k in manifest}
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


def compare(release: dict, rebuilt: dict, config: str, splits: list[str] | None = None) -> list[str]:
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
            problems.append(f"{config}/{split}: split missing from the {'release' if a is None else 'rebuild'}")
            continue
        for key in sorted((set(a) | set(b)) - _SPLIT_VOLATILE - {"boards"}):
            if a.get(key) != b.get(key):
                problems.append(f"{config}/{split}: {key} changed: {a.get(key)!r} -> {b.get(key)!r}")
        boards_a, boards_b = a.get("boards", {}), b.get("boards", {})
        for board_id in sorted(set(boards_a) | set(boards_b)):
            if board_id not in boards_b:
                problems.append(f"{config}/{split}/{board_id}: missing from the rebuild")
            elif board_id not in boards_a:
                problems.append(f"{config}/{split}/{board_id}: not in the release")
            elif boards_a[board_id] != boards_b[board_id]:
                fa, fb = boards_a[board_id], boards_b[board_id]
                what = sorted(k for k in set(fa) | set(fb) if fa.get(k) != fb.get(k))
                if "files" in what:
                    what.remove("files")
                    what = [n for n in sorted(set(fa["files"]) | set(fb.get("files", {})))
                            if fa["files"].get(n) != fb.get("files", {}).get(n)] + what
                problems.append(f"{config}/{split}/{board_id}: changed ({', '.join(what)})")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pcbdata.publish.manifests")
    verbs = parser.add_subparsers(dest="verb", required=True)
    ex = verbs.add_parser("export", help="write pcbdata/resources/releases/<config>.json.gz from a released build")
    ex.add_argument("root")
    ex.add_argument("--configs", default=None)
    ex.add_argument("--out", default="pcbdata/resources/releases")
    ch = verbs.add_parser("check", help="compare a rebuild with the committed manifests")
    ch.add_argument("root")
    ch.add_argument("--dir", default="pcbdata/resources/releases")
    args = parser.parse_args(argv)
    try:
        if args.verb == "export":
            for path in export(args.root, args.out, args.configs.split(",") if args.configs else None):
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

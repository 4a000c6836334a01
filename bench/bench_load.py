"""Benchmark of the published form of a board set.

    .venv/bin/python bench/bench_load.py [--root DIR] [--config d2] [--json OUT]

Without --root it builds the full default D2 (10 256 boards, no KiCad checks) into a temporary
folder with `pcbdata build d2`. It reports:
- the time to publish (parquet shards, card, pictures; forced rewrite),
- `datasets.load_dataset(DIR, CONFIG, split=...)` from a fresh cache, each split and all three,
  in a fresh interpreter (import time reported apart),
- the same through `pcbdata.load`, and a second (cached) load,
- parquet size versus the raw file tree, per config (bytes of the files and disk usage).
"""
from __future__ import annotations

import argparse
import atexit
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

_LOAD = r"""
import json, os, sys, time
t0 = time.perf_counter()
import datasets
t1 = time.perf_counter()
root, config, splits, via = sys.argv[1], sys.argv[2], sys.argv[3].split(","), sys.argv[4]
out = {"import_s": t1 - t0, "splits": {}}
for split in splits:
    t = time.perf_counter()
    if via == "pcbdata":
        import pcbdata
        ds = pcbdata.load(config, split=split, root=root)
    else:
        ds = datasets.load_dataset(root, config, split=split)
    out["splits"][split] = {"rows": len(ds), "seconds": time.perf_counter() - t}
t = time.perf_counter()
n = sum(len(r["board"] or "") for r in ds.select(range(min(len(ds), 1000))))
out["read_1000_boards_s"] = time.perf_counter() - t
print(json.dumps(out))
"""


def _fresh_load(root: Path, config: str, splits: list[str], via: str,
                cache: Path | None = None) -> dict:
    cache = cache or _tempdir("pcbdata-bench-cache-")
    env = dict(os.environ, HF_HOME=str(cache / "hf"), HF_DATASETS_CACHE=str(cache / "datasets"),
               HF_HUB_OFFLINE="1", HF_DATASETS_OFFLINE="1", HF_DATASETS_DISABLE_PROGRESS_BARS="1")
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-c", _LOAD, str(root), config, ",".join(splits), via],
                            capture_output=True, text=True, env=env, check=True)
    out = json.loads(result.stdout.strip().splitlines()[-1])
    out["process_s"] = time.perf_counter() - start
    return out


def _tempdir(prefix: str) -> Path:
    """A temporary folder removed when the benchmark exits."""
    path = Path(tempfile.mkdtemp(prefix=prefix))
    atexit.register(shutil.rmtree, path, ignore_errors=True)
    return path


def _tree_sizes(root: Path, config: str) -> dict:
    raw = disk = files = 0
    for dirpath, _, filenames in os.walk(root / config):
        if Path(dirpath) == root / config:
            continue  # shards and arrays live directly in <config>/
        for name in filenames:
            st = os.stat(os.path.join(dirpath, name))
            raw += st.st_size
            disk += st.st_blocks * 512
            files += 1
    parquet = sum(p.stat().st_size for p in (root / config).glob("*.parquet"))
    return {"tree_files": files, "tree_bytes": raw, "tree_disk_bytes": disk,
            "parquet_bytes": parquet, "ratio_bytes": raw / parquet if parquet else None,
            "ratio_disk": disk / parquet if parquet else None}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, help="a built set (default: build full default D2)")
    parser.add_argument("--config", default="d2")
    parser.add_argument("--json", type=Path, help="write the figures here too")
    args = parser.parse_args()
    report = {"date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
              "machine": (f"{os.cpu_count()} cores, {platform.machine()}, "
                          f"Python {platform.python_version()}"),
              "load_average": os.getloadavg()}
    root = args.root
    if root is None:
        root = _tempdir("pcbdata-bench-") / "set"
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "pcbdata", "build", "d2", "--no-check",
                        "--out", str(root)],
                       check=True, capture_output=True)
        report["build_and_publish_s"] = time.perf_counter() - t
    sys.path.insert(0, str(REPO))
    from pcbdata.model.manifest import read_manifest
    from pcbdata.publish import publish_set

    t = time.perf_counter()
    publish_set(root, [args.config], previews=3)
    report["publish_s"] = time.perf_counter() - t
    manifest = read_manifest(root)
    splits = list(manifest["configs"][args.config]["splits"])
    report["config"] = args.config
    report["boards"] = sum(s["count"] for s in manifest["configs"][args.config]["splits"].values())
    report["load_dataset_fresh"] = _fresh_load(root, args.config, splits, "datasets")
    cache = _tempdir("pcbdata-bench-cache-")
    report["pcbdata_load_fresh"] = _fresh_load(root, args.config, splits, "pcbdata", cache)
    report["pcbdata_load_cached"] = _fresh_load(root, args.config, splits, "pcbdata", cache)
    report["sizes"] = {c: _tree_sizes(root, c) for c in manifest["configs"]}
    print(json.dumps(report, indent=1))
    fresh = report["load_dataset_fresh"]
    total = sum(s["seconds"] for s in fresh["splits"].values())
    print(f"\nload_dataset({args.config}) from a fresh cache: {report['boards']} boards in "
          f"{total:.2f} s (+ import {fresh['import_s']:.2f} s); "
          f"publish {report['publish_s']:.1f} s")
    for config, size in report["sizes"].items():
        print(f"{config}: parquet {size['parquet_bytes'] / 1e6:.1f} MB "
              f"vs tree {size['tree_bytes'] / 1e6:.1f} MB "
              f"({size['tree_disk_bytes'] / 1e6:.1f} MB on disk, {size['tree_files']} files): "
              f"{size['ratio_bytes']:.1f}x / {size['ratio_disk']:.1f}x")
    if args.json:
        args.json.write_text(json.dumps(report, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

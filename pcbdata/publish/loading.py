"""Reading published sets: `load` (a `datasets.Dataset`), boards as files (`row_files`,
`materialize_row`, `iter_boards`) and `materialize` (rows of sets or shards back to a tree)."""
from __future__ import annotations

import hashlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pyarrow.parquet as pq

from pcbdata.errors import UserError
from pcbdata.fsutil import write_dir_atomic
from pcbdata.hashing import sha256_bytes, sha256_file
from pcbdata.publish.card import read_card_configs
from pcbdata.publish.layout import CARD_NAME, FILE_COLUMNS, STATE_NAME, split_key, suggest
from pcbdata.publish.verify import recorded_shard_hashes as _recorded_hashes
from pcbdata.tree import BOARD_FILE, PROJECT_FILE, REFERENCE_FILE, board_dir

ROOT_ENV = "PCBDATA_ROOT"
_HUB_ID = re.compile(r"^[A-Za-z0-9][\w.-]*/[\w.-]+$")


def _resolve_root(root) -> str | Path:
    if root is None:
        root = os.environ.get(ROOT_ENV)
        if not root:
            raise UserError(f"no board set given: pass root=DIR (a built set) or a Hub repo id "
                            f"OWNER/NAME, or set {ROOT_ENV}")
    if isinstance(root, Path) or os.path.exists(str(root)) or not _HUB_ID.match(str(root)):
        return Path(os.path.expanduser(str(root)))
    return str(root)  # a Hub dataset repository id (OWNER/NAME that is not a local folder)


def _bad_shard(root: Path, shards: list[str]) -> str | None:
    for rel in shards:
        try:
            pq.read_table(root / rel)
        except Exception as exc:  # noqa: BLE001
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            return f"{root / rel}: corrupt parquet shard ({first}); run `pcbdata verify {root}`"
    return None


def _cache_dir(root: Path, shards: list[str], recorded: dict[str, str]) -> Path:
    """A `datasets` cache folder per shard content. `datasets` keys the cache of a local folder
    by its name and the relative data file names, so two sets in folders of the same name (or a
    set rebuilt in place) could otherwise be served each other's cached rows."""
    import datasets

    digest = hashlib.sha256()
    for rel in sorted(shards):
        path = root / rel
        stamp = recorded.get(rel) or (
            (path.stat().st_size, path.stat().st_mtime_ns) if path.is_file() else "missing")
        digest.update(f"{rel}\0{stamp}\0".encode())
    return Path(datasets.config.HF_DATASETS_CACHE) / "pcbdata" / digest.hexdigest()[:20]


def load(config: str, split: str = "test", root=None, *, release: bool = False, **kwargs):
    """One config and split of a board set as a `datasets.Dataset`.

    `root` is a built and published set folder or a Hub repo id (default: $PCBDATA_ROOT);
    other keyword arguments go to `datasets.load_dataset` (e.g. `cache_dir`, `num_proc`).
    `release=True` also checks the rows against the release pinned in pcbdata (boards, file
    hashes and texts, set version, parameters) and raises UserError naming what differs; a
    local set whose manifest declares a subset of the split (a `--count` build) passes if its
    rows are the boards the manifest lists, each the released one."""
    root = _resolve_root(root)
    pinned = _pinned_release(config) if release else None  # before loading: fail fast
    ds = _load_split(config, split, root, **kwargs)
    if pinned is not None:
        _require_release(ds, pinned, split, root)
    return ds


def _load_split(config: str, split: str, root: str | Path, **kwargs):
    import datasets

    if isinstance(root, str):
        try:
            return datasets.load_dataset(root, config, split=split, **kwargs)
        except Exception as exc:  # noqa: BLE001 - Hub and network failures become one line
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise UserError(f"cannot load {root} ({config}/{split}): no such local folder, and as "
                            f"a Hub dataset: {first[:300]}") from None
    if not root.is_dir():
        raise UserError(f"{root}: no such board set folder")
    card = read_card_configs(root)
    if config not in card:
        raise suggest(config, card, "config")
    if split not in card[config]:
        raise suggest(split, card[config], "split")
    shards = card[config][split]
    recorded = _recorded_hashes(root)
    for rel in shards:
        if not (root / rel).is_file():
            raise UserError(f"{root / rel}: shard listed in the card is missing; run "
                            f"`pcbdata publish {root}` again")
        if rel in recorded and sha256_file(root / rel) != recorded[rel]:
            raise UserError(f"{root / rel}: corrupt parquet shard (its sha256 differs from "
                            f"{STATE_NAME}); run `pcbdata verify {root}`")
    if _empty_split(root, shards):
        # `datasets` cannot read a split with no rows ("corresponds to no data"), e.g. a D3 tier
        # that a small corpus leaves empty; the columns still come from the shard's schema.
        import pyarrow.parquet as pq

        return datasets.Dataset(pq.read_table(root / shards[0]))
    if "cache_dir" not in kwargs:
        # datasets prepares all splits
        every = [rel for paths in card[config].values() for rel in paths]
        kwargs["cache_dir"] = str(_cache_dir(root, every, recorded))
    try:
        return datasets.load_dataset(str(root), config, split=split, **kwargs)
    except Exception:  # noqa: BLE001
        problem = _bad_shard(root, shards)
        if problem:
            raise UserError(problem) from None
        raise


def _pinned_release(config: str):
    from pcbdata.publish.manifests import pinned_release, released_configs

    release = pinned_release(config)
    if release is None:
        raise UserError(f"{config}: no pinned release of this config in pcbdata (pinned: "
                        f"{', '.join(released_configs())}); load it without release=True")
    return release


def _require_release(ds, release, split: str, root: str | Path) -> None:
    """Raises UserError unless the loaded rows are the pinned release's (or, for a local set
    whose manifest declares fewer boards, the boards that manifest lists, each released)."""
    from pcbdata.manifest import MANIFEST_NAME, read_manifest
    from pcbdata.publish.manifests import check_release
    from pcbdata.publish.verify import release_row_problems

    config = release.config
    problems, expected = [], None
    if isinstance(root, Path) and (root / MANIFEST_NAME).is_file():
        # the manifest says whether the set is the whole split or a declared subset of it
        manifest = read_manifest(root)
        if config in manifest.get("configs", {}) and split in manifest["configs"][config]["splits"]:
            problems += check_release(manifest, [config], [split])[0].problems
            expected = set(manifest["configs"][config]["splits"][split]["boards"])
    columns = [c for c in _RELEASE_COLUMNS if c in ds.column_names]
    problems += release_row_problems(ds.select_columns(columns), release, split, expected)
    if problems:
        more = f"; ... {len(problems) - 5} more" if len(problems) > 5 else ""
        raise UserError(f"{config}/{split} of {root} does not match the pinned "
                        f"{release.describe()}: {len(problems)} problem(s): "
                        f"{'; '.join(problems[:5])}{more}")


# what `release_row_problems` reads: identity, the file texts and their hashes
_RELEASE_COLUMNS = ("board_id", "set_version", "parameters", "redistributable", "other_files",
                    *(c for pair in FILE_COLUMNS.values() for c in pair))


def _empty_split(root: Path, shards: list[str]) -> bool:
    import pyarrow.parquet as pq

    return bool(shards) and all(pq.ParquetFile(root / rel).metadata.num_rows == 0 for rel in shards)


# ---- boards as files ---------------------------------------------------------------------

def row_files(row: dict) -> dict[str, bytes]:
    """File name -> bytes of one row's board folder. Raises UserError for a recipe row."""
    if row.get("board") is None:
        raise UserError(f"{row.get('config')}/{row.get('split')}/{row.get('board_id')}: a recipe "
                        f"row (its licence does not permit redistribution): no board text; "
                        f"`pcbdata build d3` restores it from a PCBench checkout")
    files = {}
    for name, (text_col, hash_col) in FILE_COLUMNS.items():
        if row.get(text_col) is not None:
            files[name] = (row[text_col], row.get(hash_col))
    for item in row.get("other_files") or []:
        files[item["name"]] = (item["text"], item.get("sha256"))
    out = {}
    for name, (text, digest) in files.items():
        data = text.encode("utf-8")
        if digest and sha256_bytes(data) != digest:
            raise UserError(f"{row.get('board_id')}: {name} does not match its sha256 "
                            f"(damaged row)")
        out[name] = data
    return out


def materialize_row(row: dict, out_dir: str | Path, layout: str = "tree") -> Path:
    """Writes one row's board folder; returns it. `layout="tree"` gives
    `out_dir/<config>/<split>/<board_id>/` (the built set's layout), `"flat"`
    `out_dir/<board_id>/`."""
    out_dir = Path(out_dir)
    if layout == "tree":
        folder = board_dir(out_dir, row["config"], row["split"], row["board_id"])
    elif layout == "flat":
        folder = out_dir / row["board_id"]
    else:
        raise UserError(f"unknown layout {layout!r}; choose tree or flat")
    write_dir_atomic(folder, dict[str, bytes | str](row_files(row)))
    return folder


@dataclass
class BoardOnDisk:
    board_id: str
    folder: Path
    row: dict

    @property
    def board_path(self) -> Path:
        return self.folder / BOARD_FILE

    @property
    def project_path(self) -> Path:
        return self.folder / PROJECT_FILE

    @property
    def reference_path(self) -> Path | None:
        path = self.folder / REFERENCE_FILE
        return path if path.is_file() else None


def iter_boards(rows: Iterable[dict] | str, split: str = "test", root=None,
                workdir: str | Path | None = None,
                skip_recipes: bool = True) -> Iterator[BoardOnDisk]:
    """Yields every board of `rows` (a Dataset, any iterable of rows, or a config name loaded
    with `load(config, split, root)`) written as files in a folder.

    Without `workdir` each board lives in a temporary folder that is removed when the next
    board is yielded (copy what you want to keep); with `workdir` boards are kept in
    `workdir/<board_id>/`. Recipe rows are skipped (or raise with `skip_recipes=False`)."""
    source: Iterable[dict] = load(rows, split=split, root=root) if isinstance(rows, str) else rows
    for row in source:
        if row.get("board") is None and skip_recipes:
            continue
        if workdir is not None:
            yield BoardOnDisk(row["board_id"], materialize_row(row, workdir, layout="flat"), row)
            continue
        tmp = tempfile.mkdtemp(prefix="pcbdata-board-")
        try:
            yield BoardOnDisk(row["board_id"], materialize_row(row, tmp, layout="flat"), row)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


def _shards_of(source: Path, configs: list[str] | None, splits: list[str] | None) -> list[Path]:
    if source.is_file():
        return [source]
    if not source.is_dir():
        raise UserError(f"{source}: no such set folder or parquet file")
    if not (source / CARD_NAME).is_file():
        raise UserError(f"{source}: no dataset card ({CARD_NAME}); not a published set "
                        f"(run `pcbdata publish {source}`)")
    card = read_card_configs(source)
    for name in configs or []:
        if name not in card:
            raise suggest(name, card, "config")
    out = []
    for config in card:
        if configs and config not in configs:
            continue
        for split in sorted(card[config], key=split_key):
            if splits and split not in splits:
                continue
            out += [source / rel for rel in card[config][split]]
    return out


def materialize(sources: list[str | Path], out_dir: str | Path, configs: list[str] | None = None,
                splits: list[str] | None = None, board_ids: list[str] | None = None,
                layout: str = "tree") -> dict:
    """Writes the rows of published sets or parquet shards as board folders under `out_dir`.

    Returns counts: {"written", "recipes"} (recipe rows have no text and are listed, not
    written)."""
    written, recipes = 0, []
    wanted = set(board_ids or [])
    for source in sources:
        for shard in _shards_of(Path(source), configs, splits):
            try:
                parquet = pq.ParquetFile(shard)
            except Exception as exc:  # noqa: BLE001
                raise UserError(f"{shard}: not a readable parquet shard ({exc})") from None
            for batch in parquet.iter_batches(batch_size=256):
                for row in batch.to_pylist():
                    if configs and row.get("config") not in configs:
                        continue
                    if splits and row.get("split") not in splits:
                        continue
                    if wanted and row.get("board_id") not in wanted:
                        continue
                    if row.get("board") is None:
                        recipes.append(f"{row.get('config')}/{row.get('split')}/{row.get('board_id')}")
                        continue
                    materialize_row(row, out_dir, layout=layout)
                    written += 1
    return {"written": written, "recipes": recipes}

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

from pcbdata.core.errors import UserError
from pcbdata.core.fsutil import write_dir_atomic
from pcbdata.core.hashing import sha256_bytes, sha256_file
from pcbdata.core.tree import BOARD_FILE, PROJECT_FILE, REFERENCE_FILE
from pcbdata.publish.audit import recorded_shard_hashes as _recorded_hashes
from pcbdata.publish.card import read_card_configs
from pcbdata.publish.layout import CARD_NAME, FILE_COLUMNS, STATE_NAME, split_key, suggest

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
    _check_recorded(root, shards)
    if _empty_split(root, shards):
        # `datasets` cannot read a split with no rows ("corresponds to no data"), e.g. a D3 tier
        # that a small corpus leaves empty; the columns still come from the shard's schema.
        import pyarrow.parquet as pq

        return datasets.Dataset(pq.read_table(root / shards[0]))
    if "cache_dir" not in kwargs:
        kwargs["cache_dir"] = str(_cache_dir(root, shards, _recorded_hashes(root)))
    # Only this split's shards: `datasets` would otherwise prepare every split of the config,
    # and a damaged shard of another split would make this one unreadable.
    kwargs.setdefault("data_files", {split: list(shards)})
    try:
        return datasets.load_dataset(str(root), config, split=split, **kwargs)
    except Exception:  # noqa: BLE001
        problem = _bad_shard(root, shards)
        if problem:
            raise UserError(problem) from None
        raise


def _pinned_release(config: str):
    from pcbdata.sets.releases import pinned_release, released_configs

    release = pinned_release(config)
    if release is None:
        raise UserError(f"{config}: no pinned release of this config in pcbdata (pinned: "
                        f"{', '.join(released_configs())}); load it without release=True")
    return release


def _require_release(ds, release, split: str, root: str | Path) -> None:
    """Raises UserError unless the loaded rows are the pinned release's (or, for a local set
    whose manifest declares fewer boards, the boards that manifest lists, each released)."""
    from pcbdata.model.manifest import MANIFEST_NAME, read_manifest
    from pcbdata.publish.audit import release_row_problems
    from pcbdata.sets.releases import check_release

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
        name = item.get("name")
        if not _plain_name(name) or item.get("text") is None:
            raise UserError(f"{row.get('board_id')}: other file {name!r} is not a plain file "
                            f"name with text (damaged row)")
        files[name] = (item["text"], item.get("sha256"))
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
    folder = _target(row, Path(out_dir), layout)
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
        # a shard of a set folder (SET/<config>/<shard>) is checked against SET's publish.json
        root = source.resolve().parent.parent
        if (root / STATE_NAME).is_file():
            _check_recorded(root, [str(source.resolve().relative_to(root))])
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
    chosen = [c for c in card if not configs or c in configs]
    for name in splits or []:
        if not any(name in card[c] for c in chosen):
            raise suggest(name, {s for c in chosen for s in card[c]}, "split")
    out = []
    for config in chosen:
        for split in sorted(card[config], key=split_key):
            if splits and split not in splits:
                continue
            out += [source / rel for rel in card[config][split]]
    _check_recorded(source, [str(p.relative_to(source)) for p in out])
    return out


def _check_recorded(root: Path, shards: list[str]) -> None:
    """Refuses a set folder's shards the way `load` does: each must exist and match the sha256
    that `publish.json` recorded for it (a row edited in place, even with its row hash
    recomputed, changes the shard's hash)."""
    recorded = _recorded_hashes(root)
    for rel in shards:
        if not (root / rel).is_file():
            raise UserError(f"{root / rel}: shard listed in the card is missing; run "
                            f"`pcbdata publish {root}` again")
        if rel in recorded and sha256_file(root / rel) != recorded[rel]:
            raise UserError(f"{root / rel}: corrupt parquet shard (its sha256 differs from "
                            f"{STATE_NAME}); run `pcbdata verify {root}`")


def _selected_rows(sources, configs, splits, wanted: set[str]):
    """(shard, row) of every row the filters select, in source and shard order."""
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
                    yield shard, row


def _plain_name(name) -> bool:
    """A single path component: no separators, not `.`/`..`, not empty."""
    return isinstance(name, str) and name not in ("", ".", "..") and not any(
        c in name for c in "/\\\0")


def _target(row: dict, out_dir: Path, layout: str) -> Path:
    """The row's board folder under `out_dir`; its names must be plain folder names (a row
    naming `..` or a path would write outside `out_dir`)."""
    if layout not in ("tree", "flat"):
        raise UserError(f"unknown layout {layout!r}; choose tree or flat")
    keys = ("config", "split", "board_id") if layout == "tree" else ("board_id",)
    names = [row.get(key) for key in keys]
    for key, name in zip(keys, names):
        if not _plain_name(name):
            raise UserError(f"a row's {key} {name!r} is not a plain folder name; refusing to "
                            f"write it (damaged or foreign row)")
    return out_dir.joinpath(*(str(name) for name in names))


def _plan(sources, out_dir: Path, configs, splits, board_ids, layout) -> tuple[dict, list[str]]:
    """Checks every selected row before anything is written: target folder -> (shard, row
    hash), and the recipe rows. A damaged row, a requested board that is not found, or two
    different rows for one folder (e.g. the same board id of two configs with --flat) stop
    the run here."""
    targets: dict[Path, tuple[Path, str]] = {}
    recipes, found = [], set()
    for shard, row in _selected_rows(sources, configs, splits, set(board_ids or [])):
        found.add(row.get("board_id"))
        if row.get("board") is None:
            recipes.append(f"{row.get('config')}/{row.get('split')}/{row.get('board_id')}")
            continue
        files = row_files(row)
        digest = sha256_bytes(b"".join(name.encode() + b"\0" + data
                                       for name, data in sorted(files.items())))
        folder = _target(row, out_dir, layout)
        if folder in targets and targets[folder][1] != digest:
            raise UserError(f"{folder}: two different rows would be written there "
                            f"({targets[folder][0]} and {shard}); use the tree layout or "
                            f"select one config")
        targets[folder] = (shard, digest)
    missing = sorted(set(board_ids or []) - found)
    if missing:
        raise UserError(f"--board: not found in the selected rows: {', '.join(missing)}")
    return targets, recipes


def materialize(sources: list[str | Path], out_dir: str | Path, configs: list[str] | None = None,
                splits: list[str] | None = None, board_ids: list[str] | None = None,
                layout: str = "tree") -> dict:
    """Writes the rows of published sets or parquet shards as board folders under `out_dir`.

    Every row is checked first (set folders: shards against `publish.json`; rows: file
    hashes), so a refused run writes nothing. Returns counts: {"written", "recipes"} (recipe
    rows have no text and are listed, not written)."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError(f"--out {out_dir}: exists and is not a folder")
    targets, recipes = _plan(sources, out_dir, configs, splits, board_ids, layout)
    written = set()
    for _, row in _selected_rows(sources, configs, splits, set(board_ids or [])):
        if row.get("board") is None:
            continue
        folder = _target(row, out_dir, layout)
        if folder not in written:
            write_dir_atomic(folder, dict[str, bytes | str](row_files(row)))
            written.add(folder)
    return {"written": len(written), "recipes": recipes}

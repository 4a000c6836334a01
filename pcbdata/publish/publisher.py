"""`publish_set`: turns a built set (tree + manifest) into a Hugging Face dataset in place.

Atomic: shards and pictures are written into a staging folder inside the set; the commit then
removes the card, moves the staged files into place, removes stale shards, and writes
`publish.json` and the card last. The card is the commit point: while it is missing the set is
not published, so a stopped run never leaves a set that `load_dataset`, `pcbdata.load` or
`verify` take for complete. Idempotent: a config whose manifest entry and shards are unchanged
since the last run is not rewritten; rewriting gives the same bytes.
"""
from __future__ import annotations

import fcntl
import json
import os
import shutil
from contextlib import contextmanager
from pathlib import Path

import pyarrow.parquet as pq

from pcbdata.core.errors import UserError
from pcbdata.core.hashing import sha256_file, sha256_text
from pcbdata.core.textio import canonical_json
from pcbdata.core.tree import BOARD_FILE, REFERENCE_FILE, arrays_path, board_dir
from pcbdata.model.manifest import board_fact, read_manifest
from pcbdata.publish import pictures
from pcbdata.publish.card import attribution_markdown, card_text
from pcbdata.publish.layout import (
    ATTRIBUTION_NAME,
    CARD_NAME,
    INTERRUPTED_KEY,
    LOCK_NAME,
    PICTURES_DIR,
    PUBLISH_FORMAT,
    SHARD_RE,
    STAGE_NAME,
    STATE_NAME,
    TEXT_COLUMNS,
    config_key,
    shard_name,
    split_key,
    suggest,
    write_file,
)
from pcbdata.publish.real_boards import beside_picture, real_picture, tier_real_board
from pcbdata.publish.rows import (
    KNOWN_FACTS,
    is_redistributable,
    iter_rows,
    schema_for,
    table_from_rows,
)
from pcbdata.sets.configs import D3_TIERS
from pcbdata.sets.recipe import tier_rules

SHARD_BYTES = 256 * 1024 * 1024  # uncompressed text per shard
ROW_GROUP_BYTES = 32 * 1024 * 1024
ROW_GROUP_ROWS = 1000
DEFAULT_PREVIEWS = 3
_SMALL_COLUMNS = ["config", "split", "family", "set_version", "parameters"]


STUB_CARD = (f"---\n{INTERRUPTED_KEY}: true\n---\n\n"
             "# Publishing of this board set did not finish\n\n"
             "Run `pcbdata publish DIR` again; until then the set cannot be loaded.\n")


def fingerprint(manifest: dict, config: str) -> str:
    data = {"format": PUBLISH_FORMAT, "config": manifest["configs"][config],
            "kicad_version": manifest.get("kicad_version")}
    return sha256_text(json.dumps(data, sort_keys=True))


def read_state(root: Path) -> dict:
    path = root / STATE_NAME
    try:
        state = json.loads(path.read_text(encoding="utf-8"))
        if state.get("format") == PUBLISH_FORMAT:
            return state
    except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError):
        pass
    return {"format": PUBLISH_FORMAT, "configs": {}, "pictures": []}


@contextmanager
def _locked(root: Path):
    with open(root / LOCK_NAME, "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _up_to_date(root: Path, manifest: dict, config: str, state: dict) -> bool:
    entry = state["configs"].get(config)
    if not entry or entry.get("fingerprint") != fingerprint(manifest, config):
        return False
    if set(entry["splits"]) != set(manifest["configs"][config].get("splits", {})):
        return False
    for split in entry["splits"].values():
        for rel, info in split["shards"].items():
            path = root / rel
            if (not path.is_file() or path.stat().st_size != info["bytes"]
                    or sha256_file(path) != info["sha256"]):
                return False
    return (all((root / p).is_file() for p in entry.get("pictures", []))
            and _has_real_board_beside(config, manifest["configs"][config], entry))


def _has_real_board_beside(config: str, cfg: dict, entry: dict) -> bool:
    """False for a D2R config published with board previews but without its board beside a
    real one (published before cards had it)."""
    real = tier_real_board(cfg)
    pics = entry.get("pictures", [])
    previews = [p for p in pics if p != _histogram_picture(config)]
    return real is None or not previews or beside_picture(config, real) in pics


def _write_split(root: Path, stage: Path, config: str, cfg: dict, split: str,
                 has_cells: bool) -> dict:
    schema = schema_for(cfg, has_cells)
    stats_columns = [f.name for f in schema if f.name in KNOWN_FACTS or f.name in
                     ("board_id", "split", "config", "redistributable", "seed", "grid_size")]
    out_dir = stage / config
    out_dir.mkdir(parents=True, exist_ok=True)
    chunks: list[Path] = []
    writer: pq.ParquetWriter | None = None
    buffer: list[dict] = []
    buffer_bytes = shard_bytes = 0
    rows = raw_total = 0

    def open_writer():
        path = out_dir / f".chunk-{split}-{len(chunks):05d}"
        chunks.append(path)
        return pq.ParquetWriter(path, schema, compression="zstd", compression_level=9,
                                use_dictionary=_SMALL_COLUMNS, write_statistics=stats_columns,
                                write_page_checksum=True)

    def flush():
        nonlocal buffer, buffer_bytes, writer
        if buffer:
            if writer is None:
                writer = open_writer()
            writer.write_table(table_from_rows(buffer, schema))
        buffer, buffer_bytes = [], 0

    for row, raw in iter_rows(root, config, cfg, split, has_cells):
        size = sum(len(row[c] or "") for c in TEXT_COLUMNS)
        size += sum(len(f["text"] or "") for f in row["other_files"])
        if shard_bytes and shard_bytes + size > SHARD_BYTES:
            flush()
            assert writer is not None  # shard_bytes > 0: something was written
            writer.close()
            writer, shard_bytes = None, 0
        buffer.append(row)
        buffer_bytes += size
        shard_bytes += size
        rows += 1
        raw_total += raw
        if buffer_bytes >= ROW_GROUP_BYTES or len(buffer) >= ROW_GROUP_ROWS:
            flush()
    flush()
    if writer is None:  # an empty split still gets one (empty) shard so that it loads
        writer = open_writer()
        writer.write_table(table_from_rows([], schema))
    writer.close()
    shards = {}
    for k, chunk in enumerate(chunks):
        final = out_dir / shard_name(split, k, len(chunks))
        os.replace(chunk, final)
        shards[f"{config}/{final.name}"] = {"sha256": sha256_file(final),
                                            "bytes": final.stat().st_size}
    return {"rows": rows, "shards": shards, "raw_bytes": raw_total,
            "parquet_bytes": sum(s["bytes"] for s in shards.values())}


def _stage_pictures(root: Path, stage: Path, config: str, cfg: dict, previews: int,
                    renderer: pictures.PreviewRenderer) -> tuple[list[str], list[str]]:
    made = _stage_histogram(stage, config, cfg)
    jobs, rels = [], []
    sources = _preview_sources(root, config, cfg, previews)
    for board_id, panels in sources:
        rels.append(f"{PICTURES_DIR}/{config}/{board_id}.svg")
        jobs.append(pictures.PreviewJob(panels, stage / rels[-1]))
    real = tier_real_board(cfg)
    if real is not None and sources:
        _, panels = sources[len(sources) // 2]  # the middle preview by pad count
        rels.append(beside_picture(config, real))
        jobs.append(pictures.PreviewJob(panels[:1], stage / rels[-1], real_picture(real)))
    notes = []
    for rel, problem in zip(rels, renderer.render(jobs), strict=True):
        if problem:
            notes.append(f"{config}/{Path(rel).stem}: no preview ({problem})")
        else:
            made.append(rel)
    return made, notes


def _stage_histogram(stage: Path, config: str, cfg: dict) -> list[str]:
    splits = cfg.get("splits", {})
    hist_splits = ["full"] if "full" in splits else list(splits)
    pads = [board_fact(b, "n_pads") for s in hist_splits
            for b in splits[s].get("boards", {}).values() if board_fact(b, "n_pads") is not None]
    if not pads:
        return []
    rel = _histogram_picture(config)
    title = f"{config}: pad count per board ({', '.join(hist_splits)}, {len(pads)} boards)"
    write_file(stage / rel, pictures.histogram_svg({config: pads}, title))
    return [rel]


def _histogram_picture(config: str) -> str:
    return f"{PICTURES_DIR}/{config}/pads.svg"


def _preview_sources(root: Path, config: str, cfg: dict,
                     previews: int) -> list[tuple[str, list[tuple[str, Path]]]]:
    """(board id, panels) of the boards previewed on the card: the task (bare board, its
    ratsnest lines show which pads must be joined), next to the reference routing when there
    is one."""
    splits = cfg.get("splits", {})
    preview_split = "test" if "test" in splits else (sorted(splits, key=split_key) or [None])[0]
    if preview_split is None or previews <= 0:
        return []
    boards = [(bid, board_fact(b, "n_pads") or 0)
              for bid, b in splits[preview_split].get("boards", {}).items()
              if is_redistributable(b)]
    out = []
    for board_id in pictures.pick_previews(boards, previews):
        folder = board_dir(root, config, preview_split, board_id)
        panels = [(f"{board_id} task", folder / BOARD_FILE)]
        if (folder / REFERENCE_FILE).is_file():
            panels.append((f"{board_id} reference", folder / REFERENCE_FILE))
        out.append((board_id, panels))
    return out


def _d3_tier_histogram(manifest: dict, stage: Path) -> list[str]:
    """One histogram of the D3 tiers' pad counts, with the tier boundaries of the recipe the
    set was built with."""
    tiers, parameters = {}, None
    for config in D3_TIERS.values():
        cfg = manifest["configs"].get(config)
        if not cfg:
            continue
        parameters = parameters or cfg.get("parameters")
        split = "full" if "full" in cfg.get("splits", {}) else None
        boards = [b for s, e in cfg.get("splits", {}).items() if split in (None, s)
                  for b in e.get("boards", {}).values()]
        tiers[config] = [board_fact(b, "n_pads") for b in boards
                         if board_fact(b, "n_pads") is not None]
    if not any(tiers.values()):
        return []
    a, b, c = D3_TIERS["A"], D3_TIERS["B"], D3_TIERS["C"]
    boundaries = []
    if tiers.get(a) and (tiers.get(b) or tiers.get(c)):
        boundaries.append((max(tiers[a]) + 0.5, "A | B"))
    if tiers.get(b) or tiers.get(c):
        b_max_pads = tier_rules(parameters)[0].b_max_pads
        boundaries.append((b_max_pads + 0.5, f"B | C ({b_max_pads} pads)"))
    total = sum(len(v) for v in tiers.values())
    svg = pictures.histogram_svg({k: v for k, v in tiers.items() if v},
                                 f"D3: pad count per board by tier ({total} boards)", boundaries)
    rel = f"{PICTURES_DIR}/d3-tiers-pads.svg"
    write_file(stage / rel, svg)
    return [rel]


def publish_set(root: str | Path, configs: list[str] | None = None, *,
                previews: int = DEFAULT_PREVIEWS, force: bool = False, log=None) -> None:
    """Writes parquet shards, pictures and the card for the configs of `root`'s manifest.

    `configs` are (re)written even when up to date; the other configs of the manifest are
    written only if they are missing or stale, so that the card always covers the whole
    manifest. `force` rewrites everything."""
    root = Path(root)
    manifest = read_manifest(root)
    known = list(manifest.get("configs", {}))
    for name in configs or []:
        if name not in known:
            raise suggest(name, known, "config")
    if not known:
        raise UserError(f"{root}: the manifest lists no configs; nothing to publish")
    say = log or (lambda message: None)
    with _locked(root):
        state = read_state(root)
        stage = root / STAGE_NAME
        shutil.rmtree(stage, ignore_errors=True)
        stage.mkdir()
        try:
            todo = [c for c in sorted(known, key=config_key)
                    if force or c in (configs or []) or not _up_to_date(root, manifest, c, state)]
            staged = {}
            with pictures.PreviewRenderer() as renderer:
                for config in todo:
                    staged[config] = _stage_config(root, stage, manifest, config, previews,
                                                   renderer, say)
            extra = _d3_tier_histogram(manifest, stage)
            _commit(root, stage, manifest, state, staged, extra)
        finally:
            shutil.rmtree(stage, ignore_errors=True)


def _stage_config(root: Path, stage: Path, manifest: dict, config: str, previews: int,
                  renderer: pictures.PreviewRenderer, say) -> dict:
    """Writes one config's shards and pictures into the staging folder; returns its state."""
    cfg = manifest["configs"][config]
    # split arrays (D1's Connector arrays) become the cell columns
    has_cells = any(arrays_path(root, config, s).is_file() for s in cfg.get("splits", {}))
    splits = {}
    for split in sorted(cfg.get("splits", {}), key=split_key):
        say(f"publishing {config}/{split}")
        splits[split] = _write_split(root, stage, config, cfg, split, has_cells)
    made, notes = _stage_pictures(root, stage, config, cfg, previews, renderer)
    for note in notes:
        say(note)
    return {"fingerprint": fingerprint(manifest, config), "splits": splits, "pictures": made}


def _remove_published(root: Path, config: str) -> None:
    folder = root / config
    if folder.is_dir():
        for path in folder.iterdir():
            if SHARD_RE.match(path.name):
                path.unlink()
    shutil.rmtree(root / PICTURES_DIR / config, ignore_errors=True)


def _commit(root: Path, stage: Path, manifest: dict, state: dict, staged: dict,
            extra: list[str]) -> None:
    # From here until the real card is written the set is "being published": a stub card that
    # `load`, `verify` and `datasets` all refuse (so an interrupted commit never looks complete).
    write_file(root / CARD_NAME, STUB_CARD)
    gone = [c for c in state["configs"] if c not in manifest["configs"]]
    for config in list(staged) + gone:
        _remove_published(root, config)
        state["configs"].pop(config, None)
    for dirpath, _, filenames in os.walk(stage):
        for name in filenames:
            source = Path(dirpath) / name
            target = root / source.relative_to(stage)
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(source, target)
    state["configs"].update(staged)
    state["configs"] = dict(sorted(state["configs"].items(), key=lambda kv: config_key(kv[0])))
    for old in state.get("pictures", []):
        if old not in extra:
            (root / old).unlink(missing_ok=True)
    state["pictures"] = extra
    write_file(root / STATE_NAME, canonical_json(state))
    attribution = attribution_markdown(manifest)
    if attribution is None:
        (root / ATTRIBUTION_NAME).unlink(missing_ok=True)
    else:
        write_file(root / ATTRIBUTION_NAME, attribution)
    write_file(root / CARD_NAME, card_text(manifest, state))

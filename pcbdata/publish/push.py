"""`push`: uploads a published set to a Hugging Face Hub dataset repository.

Uploaded: the card, `publish.json`, `manifest.json`, `ATTRIBUTION.md`, the parquet shards,
the pictures and the D1 Connector arrays (`<config>/<split>.npz`). Not uploaded: the board
folders (the rows carry them; `pcbdata materialize` writes them back), so the Hub copy never
holds the files of boards that may not be redistributed. Re-running resumes: files already on
the Hub (same content) are not sent again. Then one tag per set version (or `--tag`).
"""
from __future__ import annotations

import os
import re
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.tree import D3_TABLES, arrays_name
from pcbdata.model.manifest import MANIFEST_NAME, read_manifest
from pcbdata.publish.audit import verify_published
from pcbdata.publish.card import read_card_configs
from pcbdata.publish.layout import ATTRIBUTION_NAME, CARD_NAME, PICTURES_DIR, STATE_NAME, config_key

# Tables the D3 build writes next to the boards (attribution, characteristics, curation report,
# the collection's licence notice): uploaded when present.
EXTRA_TOP_FILES = D3_TABLES
_REPO_RE = re.compile(r"^[A-Za-z0-9][\w.-]*/[\w.-]+$")
# What `git check-ref-format` refuses in a ref name (the Hub's tags are git tags).
_REF_BAD_CHARS = set(" ~^:?*[\\") | {chr(c) for c in range(32)} | {chr(127)}


def check_repo(repo: str) -> str:
    """OWNER/NAME as the Hub accepts it (huggingface_hub's own check: 96 characters at most,
    letters, digits, '-', '_', '.', no '--' or '..', no '.git' ending)."""
    from huggingface_hub.utils import HFValidationError, validate_repo_id

    if not _REPO_RE.match(repo):
        raise UserError(f"--repo {repo!r}: expected OWNER/NAME")
    try:
        validate_repo_id(repo)
    except HFValidationError as exc:
        raise UserError(f"--repo {repo!r}: not a valid Hub repository id ({exc})") from None
    return repo


def tag_problem(tag: str) -> str | None:
    """Why `tag` is not a valid git tag name (`git check-ref-format`), or None."""
    bad = sorted(set(tag) & _REF_BAD_CHARS)
    if not tag:
        return "empty"
    if bad:
        return "contains " + ", ".join(repr(c) for c in bad)
    if ".." in tag or "@{" in tag or "//" in tag or tag == "@":
        return "contains '..', '@{', '//' or is '@'"
    if tag.startswith(("-", "/")) or tag.endswith(("/", ".", ".lock")):
        return "starts with '-' or '/', or ends with '/', '.' or '.lock'"
    if any(part.startswith(".") or part.endswith(".lock") for part in tag.split("/")):
        return "a '/'-separated part starts with '.' or ends with '.lock'"
    if len(tag.encode("utf-8")) > 255:
        return "longer than 255 bytes"
    return None


def check_tags(tags: list[str]) -> list[str]:
    for tag in tags:
        problem = tag_problem(tag)
        if problem:
            raise UserError(f"--tag {tag!r}: not a valid git tag ({problem})")
    return tags


def files_to_push(root: Path) -> list[str]:
    """Relative paths of the files `push` uploads, in a stable order."""
    card = read_card_configs(root)
    out = [CARD_NAME, STATE_NAME, MANIFEST_NAME]
    out += [name for name in (ATTRIBUTION_NAME, *EXTRA_TOP_FILES) if (root / name).is_file()]
    for config in sorted(card, key=config_key):
        for split, shards in card[config].items():
            out += shards
            npz = f"{config}/{arrays_name(split)}"
            if (root / npz).is_file():
                out.append(npz)
    pictures = root / PICTURES_DIR
    if pictures.is_dir():
        out += sorted(str(p.relative_to(root)) for p in pictures.rglob("*.svg"))
    return out


def default_tags(manifest: dict) -> list[str]:
    """One tag per family and set version, e.g. `d2-v1.0.0`."""
    tags = {f"{cfg.get('family', name)}-v{cfg.get('set_version', '0')}"
            for name, cfg in manifest.get("configs", {}).items()}
    return sorted(tags)


def push(root: str | Path, repo: str, tags: list[str] | None = None, dry_run: bool = False,
         private: bool = False, token: str | None = None, say=print) -> list[str]:
    """Uploads the published set at `root` to the dataset repo `repo`; returns the file list."""
    root = Path(root)
    check_repo(repo)
    check_tags(tags or [])  # before anything is read or sent
    manifest = read_manifest(root)
    problems = verify_published(root, manifest)
    if problems:
        raise UserError(f"{root}: not ready to push ({len(problems)} problems, first: "
                        f"{problems[0]}); run `pcbdata verify {root}`")
    files = files_to_push(root)
    tags = tags or default_tags(manifest)
    total = sum((root / f).stat().st_size for f in files)
    if dry_run:
        for rel in files:
            say(f"{(root / rel).stat().st_size:>12}  {rel}")
        say(f"would upload {len(files)} files ({total / 1e6:.1f} MB) to "
            f"https://huggingface.co/datasets/{repo} and tag {', '.join(tags)}")
        return files
    if os.environ.get("HF_HUB_OFFLINE", "").lower() in ("1", "true", "yes", "on"):
        raise UserError("cannot push: HF_HUB_OFFLINE is set (the Hugging Face Hub is not reachable "
                        "offline); unset it and run again")
    try:
        from huggingface_hub import HfApi

        api = HfApi(token=token)
        api.create_repo(repo, repo_type="dataset", private=private, exist_ok=True)
        api.upload_folder(folder_path=str(root), repo_id=repo, repo_type="dataset",
                          allow_patterns=files,
                          commit_message=f"pcbdata set ({', '.join(tags)})")
        for tag in tags:
            api.create_tag(repo, tag=tag, repo_type="dataset", exist_ok=True)
    except UserError:
        raise
    except Exception as exc:  # noqa: BLE001 - network, auth and Hub errors: one clear line
        first = str(exc).splitlines()[0] if str(exc) else ""
        raise UserError(f"cannot push to the Hugging Face Hub ({repo}): {type(exc).__name__}: "
                        f"{first[:300]} (check the network and `hf auth login`; re-running "
                        f"resumes)") from None
    say(f"uploaded {len(files)} files ({total / 1e6:.1f} MB) to "
        f"https://huggingface.co/datasets/{repo}; "
        f"tags: {', '.join(tags)}")
    return files

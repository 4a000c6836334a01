"""Per-board attribution: source repository, author, licence (SPDX id where known) and whether
the licence permits redistribution, from `metadata.json` and `github_meta/*.json`."""
from __future__ import annotations

import json
from pathlib import Path

UNKNOWN = "NOASSERTION"


def load_github_licences(source: str | Path, recipe,
                         problems: list[str] | None = None) -> dict[str, dict]:
    """Repository URL -> {"spdx_id", "name", "owner"} from the GitHub search results. A file
    that cannot be read is skipped with its reason appended to `problems`."""
    problems = [] if problems is None else problems
    folder_name = recipe.source.github_meta_dir
    folder = Path(source) / folder_name
    repos: dict[str, dict] = {}
    if not folder.is_dir():
        problems.append(f"{folder_name}/: no such folder; licences come from metadata.json only")
        return repos
    for path in sorted(folder.glob("*.json")):
        try:
            data = json.loads(path.read_bytes().decode("utf-8"))
        except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
            problems.append(f"{folder_name}/{path.name}: skipped, not readable JSON "
                            f"({type(exc).__name__})")
            continue
        if not isinstance(data, dict) or not isinstance(data.get("items", []), list):
            problems.append(f"{folder_name}/{path.name}: skipped, not a search result "
                            f"(no items list)")
            continue
        for item in data.get("items", []):
            if not isinstance(item, dict) or not isinstance(item.get("html_url"), str):
                continue  # not a repository entry (search results hold only those)
            lic = item.get("license") or {}
            owner_entry = item.get("owner")
            owner = owner_entry.get("login", "") if isinstance(owner_entry, dict) else ""
            repos.setdefault(item["html_url"].rstrip("/"), {
                "spdx_id": (lic.get("spdx_id") or "") if isinstance(lic, dict) else "",
                "name": (lic.get("name") or "") if isinstance(lic, dict) else "",
                "owner": owner})
    return repos


def _from_metadata(value, names: dict[str, str]) -> tuple[str, str]:
    """(spdx id or "", raw text) of a metadata.json `licenses` value."""
    if isinstance(value, dict):
        spdx = value.get("spdx_id") or ""
        return ("" if spdx == UNKNOWN else spdx), str(value.get("name") or spdx)
    if isinstance(value, list):
        raw = "; ".join(str(v.get("name", "")) for v in value if isinstance(v, dict))
        ids = {names.get(str(v.get("name", "")).strip(), "") for v in value if isinstance(v, dict)}
        ids.discard("")
        return (ids.pop() if len(ids) == 1 else ""), raw
    return "", str(value or "")


def attribute(name: str, metadata: dict | None, github: dict[str, dict], recipe) -> dict:
    lic_cfg = recipe.licences
    names = lic_cfg.names
    meta = metadata or {}
    repo = str(meta.get("source") or "").rstrip("/")
    gh = github.get(repo, {})
    spdx, raw = _from_metadata(meta.get("licenses"), names)
    origin = "metadata.json" if spdx else ""
    if not spdx and gh.get("spdx_id") and gh["spdx_id"] != UNKNOWN:
        spdx, origin = gh["spdx_id"], "github_meta"
        raw = raw or gh.get("name", "")
    author = str(meta.get("author") or "") or gh.get("owner", "")
    if not author and repo.startswith("https://github.com/"):
        author = repo.split("/")[3] if len(repo.split("/")) > 3 else ""
    return {
        "name": name,
        "source_repository": repo,
        "author": author,
        "licence": spdx or UNKNOWN,
        "licence_text": raw,
        "licence_from": origin or "unknown",
        "redistributable": bool(spdx) and spdx in set(lic_cfg.redistributable),
        "collection_licence": recipe.source.collection_licence,
    }

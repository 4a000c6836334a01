"""Declarative files shipped with the package (data, not code):

- `presets/d1.toml`, `presets/d2_levels.toml`: the versioned generator presets (D1, D2 levels);
- `recipes/d3.toml`: the versioned D3 curation recipe;
- `releases/<config>.json.gz`: the manifest of every released default set.
- `real_boards/`: the real board of each D3 tier pictured beside a D2R level on its card;
- `policy/`: the shipped learned policy and its model card.

`resource_path(*parts)` gives a file's path; nothing here imports the rest of pcbdata.
"""
from __future__ import annotations

from importlib import resources
from importlib.abc import Traversable


def resource_path(*parts: str) -> Traversable:
    """A packaged resource, e.g. `resource_path("presets", "d1.toml")`."""
    node = resources.files(__name__)
    for part in parts:
        node = node.joinpath(part)
    return node

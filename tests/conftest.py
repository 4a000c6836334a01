"""Test session set-up: offline, with every cache (Hugging Face, datasets, KiCad config) in a
temporary folder, so tests neither read nor write the user's files."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

_CACHE_ROOT = Path(tempfile.mkdtemp(prefix="pcbdata-test-caches-"))
for _var, _sub in (("HF_HOME", "hf"), ("HF_DATASETS_CACHE", "hf/datasets"),
                   ("KICAD_CONFIG_HOME", "kicad-config"), ("XDG_CONFIG_HOME", "xdg-config"),
                   ("XDG_CACHE_HOME", "xdg-cache")):
    os.environ[_var] = str(_CACHE_ROOT / _sub)
    (_CACHE_ROOT / _sub).mkdir(parents=True, exist_ok=True)
os.environ["HF_HUB_OFFLINE"] = "1"
os.environ["HF_DATASETS_OFFLINE"] = "1"

REPO_ROOT = Path(__file__).resolve().parent.parent
SHARED_PCBENCH = REPO_ROOT.parent / "shared" / "pcbench" / "pcbench.tar.xz"


@pytest.fixture(scope="session")
def kicad_pool():
    """One pool of KiCad worker processes shared by the whole test session."""
    from pcbdata.kicad import KicadPool

    with KicadPool(workers=2, task_timeout=300) as pool:
        yield pool

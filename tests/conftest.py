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


@pytest.fixture(scope="session")
def ray_cluster():
    """A Ray cluster of 2 CPUs on this machine, loopback only, for the whole session; skips
    where Ray is not installed (`pip install 'pcbdata[ray]'`). Its workers import pcbdata and
    the tests from this checkout (PYTHONPATH, inherited from here)."""
    import os

    saved = {k: os.environ.get(k) for k in ("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "PYTHONPATH",
                                             "RAY_USAGE_STATS_ENABLED")}
    # Ray binds to loopback when it believes it cannot form a cluster (read at import).
    os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"  # offline: no usage report
    ray = pytest.importorskip("ray", reason="Ray is not installed (pip install 'pcbdata[ray]')")
    from ray._private import ray_constants

    ray_constants.ENABLE_RAY_CLUSTER = False  # in case Ray was imported before
    os.environ["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(REPO_ROOT), saved["PYTHONPATH"] or "") if p)
    assert not ray.is_initialized(), "a Ray cluster is already running in this process"
    # address="local": always a new cluster, never one left on the machine by `ray start`
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
             _node_ip_address="127.0.0.1")
    try:
        yield ray
    finally:
        ray.shutdown()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value

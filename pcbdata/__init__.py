"""pcbdata: board sets, curation and KiCad-checked scoring for PCBWorld-Bench."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("pcbdata")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.2.0"


def load(config: str, split: str = "test", root=None, **kwargs):
    """Loads one config and split of a built board set as a `datasets.Dataset`."""
    from pcbdata.publish import load as _load

    return _load(config, split=split, root=root, **kwargs)

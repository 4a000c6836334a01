"""pcbdata: board sets, curation and KiCad-checked scoring for PCBWorld-Bench."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("pcbdata")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0"

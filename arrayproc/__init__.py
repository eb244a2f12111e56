"""arrayproc: hydrophone-array processing, from recordings to bearings, delays and tracks."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("arrayproc")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]

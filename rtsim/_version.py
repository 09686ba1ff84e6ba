"""The installed version of rtsim (``rtsim.__version__``), for modules inside the package that
must not import the top-level facade."""

from importlib.metadata import PackageNotFoundError, version

__all__ = ["__version__"]

try:
    __version__ = version("rtsim")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

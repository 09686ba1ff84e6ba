"""rtsim's version (``rtsim.__version__``): one static string, the source the package metadata
takes (pyproject.toml reads it with ``attr:``), so that no command pays for a metadata look-up
at start-up; for modules inside the package that must not import the top-level facade."""

__all__ = ["__version__"]

__version__ = "0.1.0"

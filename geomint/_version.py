"""The one version string of geomint (pyproject.toml reads it)."""

__version__ = "0.1.0"

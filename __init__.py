"""xicm: cross-task in-context manipulation (X-ICM) on an AGNOSTOS re-creation in SAPIEN.

The repository root is the `xicm` package (see pyproject.toml's package-dir mapping):
core/ -> xicm.core, plugins/ -> xicm.plugins, conf/ -> xicm.conf.
"""

from xicm.core import __version__

__all__ = ["__version__"]

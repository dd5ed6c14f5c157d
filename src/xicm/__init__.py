"""xicm: cross-task in-context manipulation (X-ICM) on an AGNOSTOS re-creation in SAPIEN.

The package `xicm` is `src/xicm/` (see pyproject.toml's package-dir mapping):
src/xicm/core/ -> xicm.core, src/xicm/plugins/ -> xicm.plugins, src/xicm/conf/ -> xicm.conf.
"""

from xicm.core import __version__

__all__ = ["__version__"]

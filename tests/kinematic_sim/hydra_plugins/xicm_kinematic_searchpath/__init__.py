"""Adds xicm_kinematic/conf to Hydra's config search path, so that `simulator=kinematic` is found."""

from hydra.core.config_search_path import ConfigSearchPath
from hydra.plugins.search_path_plugin import SearchPathPlugin


class KinematicSearchPath(SearchPathPlugin):
    def manipulate_search_path(self, search_path: ConfigSearchPath) -> None:
        search_path.append(provider="xicm-kinematic", path="pkg://xicm_kinematic.conf")

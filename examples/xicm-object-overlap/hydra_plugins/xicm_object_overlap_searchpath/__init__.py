"""Adds this package's conf/ folder to Hydra's config search path, so that
`xicm-eval retriever=object_overlap` finds conf/retriever/object_overlap.yaml."""

from hydra.core.config_search_path import ConfigSearchPath
from hydra.plugins.search_path_plugin import SearchPathPlugin


class ObjectOverlapSearchPath(SearchPathPlugin):
    def manipulate_search_path(self, search_path: ConfigSearchPath) -> None:
        search_path.append(provider="xicm-object-overlap", path="pkg://xicm_object_overlap.conf")

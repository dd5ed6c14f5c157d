"""Retriever "dynamics": X-ICM's dynamics-guided selection, cosine top-K over `dynamics` encoder
features (src/xicm/plugins/encoders/dynamics.py). The ranking and the on-disk pool-feature cache are
the similarity retriever's; pool features are keyed by the checkpoint's hash, the encoder's
options and the pool's demos and first frames, so every evaluation job reuses them.

Options: as the similarity retriever (cache_dir, exclude_same_task, score).
"""

from __future__ import annotations

from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.plugins.retrievers.similarity import SimilarityOptions, SimilarityRetriever


class DynamicsRetriever(SimilarityRetriever):
    def __init__(self, options: SimilarityOptions | None = None, encoder=None):
        if encoder is not None and not getattr(encoder, "uses_images", False):
            raise ConfigError(
                f"the dynamics retriever needs an encoder of the scene's dynamics (encoder=dynamics), got {type(encoder).__name__}"
            )
        super().__init__(options, encoder=encoder)


@hookimpl
def register_retrievers(register):
    register("dynamics", DynamicsRetriever, options=SimilarityOptions)

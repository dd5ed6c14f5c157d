"""The model of `transformers_local`: which files the ``model`` option names, and loading them
offline (tokenizer, weights, dtype, device, the chat-template choice). Options:
`xicm.plugins.llms.transformers_local_options`; the LLM holds one `LoadedModel`."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

from xicm.core.contracts.errors import ConfigError
from xicm.plugins.llms import model_files
from xicm.plugins.llms.prefix_cache import PrefixCache


def resolve_model(model: str, cache_dir: str | None) -> tuple[str, str | None, str]:
    """(path or model id to load, gguf file name or None, label for identity())."""
    if model == model_files.EMBEDDED:
        package = model_files.embedded_package()
        target = model_files.embedded_model_dir(cache_dir, convert=False)
        return str(target), None, f"embedded:{model_files.embedded_folder_name(package)}"
    path = Path(model).expanduser()
    if path.is_dir():
        if not (path / "config.json").is_file():
            ggufs = sorted(p.name for p in path.glob("*.gguf"))
            if len(ggufs) == 1:
                return str(path), ggufs[0], f"{path.resolve() / ggufs[0]}#{model_files.fingerprint(path / ggufs[0])}"
            raise ConfigError(
                f"llm model folder {path} has no config.json; it contains: "
                f"{', '.join(sorted(p.name for p in path.iterdir())) or 'nothing'}"
            )
        return str(path), None, f"{path.resolve()}#{model_files.fingerprint(path)}"
    if path.is_file() and path.suffix == ".gguf":
        return str(path.parent), path.name, f"{path.resolve()}#{model_files.fingerprint(path)}"
    if path.exists():
        raise ConfigError(f"llm model {path} is neither a model folder nor a .gguf file")
    if model_files.looks_like_path(model):
        raise ConfigError(
            f"llm model path {path} does not exist; {model_files.describe_missing(path)} "
            f"(or use model: embedded)"
        )
    if not model_files.hf_cached(model):
        raise ConfigError(
            f"llm model '{model}' is not a local folder and is not in the local Hugging Face cache "
            f"(nothing is downloaded); use model: embedded or a local model folder"
        )
    return model, None, f"hf:{model}"


class LoadedModel:
    """The model of `transformers_local`: the files the ``model`` option names (resolved when
    built: a missing model is a ConfigError before any episode) and, once `load()` ran, the
    tokenizer, the weights, the rendering the chat_template option chose (`template_used`) and
    whether the fast path can reuse its key/value cache (`cache_supported`)."""

    def __init__(self, model: str, cache_dir: str | None, dtype: str, device: str, torch_threads: int | None,
                 trust_remote_code: bool, chat_template: str):
        self.option, self.cache_dir = model, cache_dir
        self.dtype_name, self.device_option, self.torch_threads = dtype, device, torch_threads
        self.trust_remote_code, self.chat_template = trust_remote_code, chat_template
        self.source, self.gguf_file, self.label = resolve_model(model, cache_dir)
        self.model = None
        self.tokenizer = None
        self.template_used: str | None = None  # 'tokenizer', 'custom', 'plain' or 'raw' once loaded
        self.cache_supported = False
        self.load_seconds: float | None = None

    def load(self) -> None:
        """Load tokenizer and weights (converting the embedded model first if needed)."""
        if self.model is not None:
            return
        os.environ["HF_HUB_OFFLINE"] = "1"
        import torch
        from transformers import AutoModelForCausalLM, AutoTokenizer

        if self.torch_threads:
            torch.set_num_threads(self.torch_threads)
        t0 = time.perf_counter()
        source = self.source
        if self.option == model_files.EMBEDDED:
            source = str(model_files.embedded_model_dir(self.cache_dir))
        dtype = getattr(torch, self.dtype_name, None) if self.dtype_name != "auto" else "auto"
        if dtype is None:
            raise ConfigError(f"llm.dtype '{self.dtype_name}' is not a torch dtype (e.g. float32, bfloat16, auto)")
        kwargs: dict[str, Any] = {"local_files_only": True}
        if self.trust_remote_code:
            kwargs["trust_remote_code"] = True
        if self.gguf_file:
            kwargs["gguf_file"] = self.gguf_file
        try:
            tokenizer = AutoTokenizer.from_pretrained(source, **kwargs)
            model = AutoModelForCausalLM.from_pretrained(source, dtype=dtype, **kwargs)
        except OSError as exc:
            raise ConfigError(f"llm model {source} could not be loaded offline: {exc}") from exc
        model.to(self.device)
        model.eval()
        self.tokenizer = tokenizer
        self.model = model
        self.template_used = self._choose_template(tokenizer)
        self.cache_supported = PrefixCache.supported(model)
        self.load_seconds = time.perf_counter() - t0

    @property
    def device(self) -> str:
        if self.device_option != "auto":
            return self.device_option
        import torch

        return "cuda" if torch.cuda.is_available() else "cpu"

    def _choose_template(self, tokenizer) -> str:
        has_template = bool(getattr(tokenizer, "chat_template", None))
        mode = self.chat_template
        if mode in ("plain", "raw"):
            return mode
        if mode == "auto":
            return "tokenizer" if has_template else "plain"
        if mode == "tokenizer":
            if not has_template:
                raise ConfigError(
                    f"llm.chat_template is 'tokenizer' but the tokenizer of {self.source} has no chat template; "
                    "use chat_template: auto or plain"
                )
            return "tokenizer"
        return "custom"

    @property
    def context_length(self) -> int | None:
        self.load()
        config = self.model.config
        for attr in ("max_position_embeddings", "n_positions", "max_sequence_length"):
            value = getattr(config, attr, None)
            if isinstance(value, int) and value > 0:
                return value
        return None

    def decode(self, new_ids: list[int]) -> str:
        return self.tokenizer.decode(new_ids, skip_special_tokens=True)

    def vocab_size(self) -> int:
        return int(self.model.get_output_embeddings().weight.shape[0])

    def eos_ids(self) -> list[int]:
        eos = self.model.generation_config.eos_token_id
        return [] if eos is None else [eos] if isinstance(eos, int) else list(eos)

    def pad_id(self) -> int:
        pad = self.tokenizer.pad_token_id
        return self.tokenizer.eos_token_id if pad is None else pad

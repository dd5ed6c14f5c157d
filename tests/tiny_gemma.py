"""A tiny randomly initialised Gemma 3 and a character-level tokenizer, built offline in about a
second: what the transformers_local tests run on instead of a downloaded model. The session
fixture `tiny_gemma_dir` (conftest.py) writes one folder for every LLM test module."""

from __future__ import annotations

import string
from pathlib import Path

#: context length of the shared tiny model (long enough for the fast-path tests' prompts)
TINY_GEMMA_POSITIONS = 1024


def build_tokenizer(chat_template: str | None = None):
    """A character-level tokenizer built in memory (no download): ids 0-3 are special."""
    from tokenizers import Regex, Tokenizer, decoders, models, pre_tokenizers, processors
    from transformers import PreTrainedTokenizerFast

    specials = ["<pad>", "<eos>", "<bos>", "<unk>", "<start_of_turn>", "<end_of_turn>"]
    chars = list(dict.fromkeys(string.printable))
    vocab = {token: i for i, token in enumerate(specials + chars)}
    core = Tokenizer(models.WordLevel(vocab, unk_token="<unk>"))
    core.pre_tokenizer = pre_tokenizers.Split(Regex(r"[\s\S]"), behavior="isolated")
    core.decoder = decoders.Fuse()
    core.post_processor = processors.TemplateProcessing(single="<bos> $A", special_tokens=[("<bos>", 2)])
    tokenizer = PreTrainedTokenizerFast(
        tokenizer_object=core, bos_token="<bos>", eos_token="<eos>", pad_token="<pad>", unk_token="<unk>",
        additional_special_tokens=["<start_of_turn>", "<end_of_turn>"],
    )
    if chat_template:
        tokenizer.chat_template = chat_template
    return tokenizer


def build_model(vocab_size: int, seed: int = 0, max_positions: int = 256):
    from transformers import Gemma3ForCausalLM, Gemma3TextConfig

    config = Gemma3TextConfig(
        vocab_size=vocab_size, hidden_size=32, intermediate_size=64, num_hidden_layers=2,
        num_attention_heads=2, num_key_value_heads=1, head_dim=16, max_position_embeddings=max_positions,
        sliding_window=16, layer_types=["sliding_attention", "full_attention"],
        bos_token_id=2, eos_token_id=1, pad_token_id=0, tie_word_embeddings=True,
    )
    import torch

    torch.manual_seed(seed)
    return Gemma3ForCausalLM(config).eval()


def write_tiny_gemma(out: Path, max_positions: int = TINY_GEMMA_POSITIONS) -> Path:
    """The tiny model (seed 0) written to `out` the way the embedded conversion writes a folder."""
    from xicm.plugins.llms import model_files

    tokenizer = build_tokenizer()
    model_files.write_model_folder(build_model(len(tokenizer), max_positions=max_positions), tokenizer, out, {"source": "test"})
    return out

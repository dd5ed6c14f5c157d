"""A tiny, randomly initialised Grounding DINO of the real architecture, saved like a checkpoint.

It finds nothing meaningful; it exists so that the grounding_dino detector's whole code path
(processor, model, post-processing, 3D lifting) runs offline in tests and benchmarks on a
machine without the real weights. The tokenizer is a BERT word-piece tokenizer whose
vocabulary is built locally from the given words.

    python tests/tiny_grounding_dino.py OUT_DIR [words ...]
"""

from __future__ import annotations

import sys
from pathlib import Path

SPECIAL = ["[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]", ".", ","]


def build_tiny_grounding_dino(out_dir: str | Path, words, image_size: int = 128, seed: int = 0) -> Path:
    import torch
    from transformers import (
        BertConfig,
        BertTokenizer,
        GroundingDinoConfig,
        GroundingDinoForObjectDetection,
        GroundingDinoImageProcessor,
        GroundingDinoProcessor,
        SwinConfig,
    )

    vocab = list(dict.fromkeys(SPECIAL + sorted({w.lower() for text in words for w in text.split()})))
    tokenizer = BertTokenizer(vocab={w: i for i, w in enumerate(vocab)}, do_lower_case=True)
    images = GroundingDinoImageProcessor(size={"shortest_edge": image_size, "longest_edge": image_size})
    config = GroundingDinoConfig(
        backbone_config=SwinConfig(
            image_size=image_size, patch_size=4, embed_dim=16, depths=[1, 1, 1, 1], num_heads=[1, 1, 2, 2],
            window_size=4, out_features=["stage2", "stage3", "stage4"],
        ),
        text_config=BertConfig(
            vocab_size=len(vocab), hidden_size=32, num_hidden_layers=1, num_attention_heads=2,
            intermediate_size=64, max_position_embeddings=64,
        ),
        d_model=32, encoder_layers=1, decoder_layers=2, encoder_ffn_dim=64, decoder_ffn_dim=64,
        encoder_attention_heads=2, decoder_attention_heads=2, num_queries=30, max_text_len=64,
    )
    torch.manual_seed(seed)
    model = GroundingDinoForObjectDetection(config).eval()
    out = Path(out_dir)
    model.save_pretrained(out)
    GroundingDinoProcessor(image_processor=images, tokenizer=tokenizer).save_pretrained(out)
    return out


if __name__ == "__main__":
    target = sys.argv[1] if len(sys.argv) > 1 else "tiny-grounding-dino"
    print(build_tiny_grounding_dino(target, sys.argv[2:] or ["object"]))

"""Several prompts through one `generate` call (left padding), each row stopping on its own.

On a CPU, decoding is bound by reading the weights once per step; a batch reads them once
for all its rows, so B replies take much less than B times one reply. Greedy replies equal
the one-by-one replies up to floating-point rounding of the padded batch (the tests and
benchmarks/bench_llm_stage.py compare them); sampled replies differ (the draws are shared).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from xicm.plugins.llms.stopping import StopRules


def left_pad(id_lists: Sequence[Sequence[int]], pad_id: int):
    """(input_ids, attention_mask) tensors with every row padded on the left to the longest."""
    import torch

    width = max(len(ids) for ids in id_lists)
    input_ids = torch.full((len(id_lists), width), int(pad_id), dtype=torch.long)
    mask = torch.zeros((len(id_lists), width), dtype=torch.long)
    for row, ids in enumerate(id_lists):
        if ids:
            input_ids[row, width - len(ids):] = torch.tensor(list(ids), dtype=torch.long)
            mask[row, width - len(ids):] = 1
    return input_ids, mask


def generate_batch(
    model,
    id_lists: Sequence[Sequence[int]],
    pad_id: int,
    decode: Callable[[list[int]], str],
    rules: StopRules,
    generation_kwargs: dict[str, Any],
) -> list[list[int]]:
    """New token ids per prompt (padding removed), each row stopped once its reply ends."""
    import torch

    if not id_lists:
        return []
    input_ids, mask = left_pad(id_lists, pad_id)
    device = next(model.parameters()).device
    input_ids, mask = input_ids.to(device), mask.to(device)
    width = input_ids.shape[1]
    criteria = rules.criteria(decode, width)
    from transformers import StoppingCriteriaList

    with torch.inference_mode():
        out = model.generate(
            input_ids=input_ids, attention_mask=mask, pad_token_id=pad_id,
            stopping_criteria=StoppingCriteriaList([criteria]), **generation_kwargs,
        )
    rows = []
    for row in out[:, width:].tolist():
        while row and row[-1] == pad_id:  # rows that ended early are filled with padding
            row.pop()
        rows.append(row)
    return rows

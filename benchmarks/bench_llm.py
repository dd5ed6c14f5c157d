"""Performance of the embedded Gemma 3 270M through transformers_local (prints figures; not a test).

    .venv/bin/python benchmarks/bench_llm.py              # converts into a temporary cache (~80 s)
    .venv/bin/python benchmarks/bench_llm.py --cache-dir ~/.cache/xicm/models   # reuse a cache

Prints: first load (GGUF conversion) seconds, cached load seconds, seconds for a ~3k-token
X-ICM-style prompt + 128 new tokens (greedy, exactly 128 generated), prefill and decode rates.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time

from xicm.core.text.encoding import format_ints

SYSTEM = (
    "You are a Franka Panda robot with a parallel gripper. We provide you with some demos in the format of "
    "[task_instruction, observation]>[7-dim action_1, 7-dim action_2, ..., 7-dim action_N]. Output a list of "
    "7-dim actions for the unseen task that matches the trends in the demos. Do not output anything else."
)


def demo_line(i: int) -> str:
    """One synthetic demo: instruction, three objects, six 7-integer key actions."""
    base = [(17 * i + 11) % 90, (29 * i + 7) % 90, 10 + i % 20]
    objects = ", ".join(
        f"{name} {format_ints([base[0] + k * 3, base[1] - k * 2, base[2]])}" for k, name in enumerate(("jar", "lid", "table"))
    )
    actions = ", ".join(
        format_ints([base[0] + s, base[1] + s, base[2] + 10 - s, 0, 36, (i + s) % 72, s % 2]) for s in range(6)
    )
    return f"close the red jar, {objects}>[{actions}]"


def build_messages(tokenizer, target_tokens: int) -> tuple[list[dict[str, str]], int]:
    lines: list[str] = []
    query = "close microwave, microwave [55, 40, 12], door [60, 35, 14]>"
    while True:
        user = "\n".join([*lines, query])
        n = len(tokenizer(SYSTEM + "\n\n" + user)["input_ids"])
        if n >= target_tokens:
            return [{"role": "system", "content": SYSTEM}, {"role": "user", "content": user}], n
        lines.append(demo_line(len(lines)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache-dir", help="models cache to use (default: a fresh temporary one)")
    parser.add_argument("--prompt-tokens", type=int, default=3000)
    parser.add_argument("--new-tokens", type=int, default=128)
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default: torch's choice)")
    args = parser.parse_args()

    from xicm.plugins.llms.model_files import embedded_model_dir
    from xicm.plugins.llms.transformers_local import TransformersLocalLLM
    from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

    tmp = None if args.cache_dir else tempfile.mkdtemp(prefix="xicm-bench-llm-")
    cache = args.cache_dir or tmp
    try:
        had_folder = embedded_model_dir(cache, convert=False).exists()
        options = dict(cache_dir=cache, chat_template="raw", stop=None, torch_threads=args.threads,
                       max_new_tokens=args.new_tokens, max_prompt_tokens=8192)
        t0 = time.perf_counter()
        TransformersLocalLLM(TransformersLocalOptions(**options)).load()
        first = time.perf_counter() - t0
        t0 = time.perf_counter()
        llm = TransformersLocalLLM(TransformersLocalOptions(**options))
        llm.load()
        cached = time.perf_counter() - t0

        import torch

        messages, _ = build_messages(llm.loaded.tokenizer, args.prompt_tokens)
        ids = llm.prompts.fit(llm.prompts.encode(messages))
        input_ids = torch.tensor([ids])
        def generate(n: int):
            return llm.loaded.model.generate(
                input_ids=input_ids, attention_mask=torch.ones_like(input_ids), do_sample=False,
                temperature=None, top_p=None, top_k=None, max_new_tokens=n,
                min_new_tokens=n, pad_token_id=llm.loaded.tokenizer.pad_token_id,
            )

        with torch.inference_mode():
            llm.loaded.model(input_ids[:, :32], logits_to_keep=1)  # warm-up
            t0 = time.perf_counter()
            generate(1)  # prefill + one token
            prefill = time.perf_counter() - t0
            t0 = time.perf_counter()
            out = generate(args.new_tokens)
            total = time.perf_counter() - t0
        new = out.shape[1] - input_ids.shape[1]
        decode = max(total - prefill, 1e-9)  # the remaining new - 1 tokens
        print(f"torch threads: {torch.get_num_threads()}, cpu count: {os.cpu_count()}")
        print(f"first load ({'folder already there' if had_folder else 'GGUF conversion'}): {first:.1f} s")
        print(f"cached load (converted folder): {cached:.1f} s")
        print(f"prompt {len(ids)} tokens + {new} new tokens: {total:.1f} s")
        print(f"  prefill (prompt + 1 token, measured separately) {prefill:.1f} s ({len(ids) / prefill:.0f} prompt tokens/s)")
        print(f"  decode ~{decode:.1f} s ({(new - 1) / decode:.1f} new tokens/s); overall {new / total:.1f} new tokens/s")
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()

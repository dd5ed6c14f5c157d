"""LLMs: prompt messages -> reply text (transformers_local, openai_compatible, llamacpp, nearest_demo)."""

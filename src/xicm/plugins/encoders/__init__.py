"""Encoders: a feature per demo and per query for the similarity retrievers (minilm, dynamics)."""

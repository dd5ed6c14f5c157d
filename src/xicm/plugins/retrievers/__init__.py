"""Retrievers: the K demos of the pool a prompt shows (random, similarity, dynamics)."""

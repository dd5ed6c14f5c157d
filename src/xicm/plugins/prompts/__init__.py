"""Prompt builders: demos and query -> chat messages (xicm, xicm_paper)."""

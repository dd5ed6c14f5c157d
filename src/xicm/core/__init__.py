"""The core, in layers: contracts (types, interfaces, hookspecs), assembly (from config to a live run), execution
(episodes, workers), results (what a run leaves) and text (scene and action text); it names no plugin. No heavy
imports here."""

__version__ = "0.1.0"

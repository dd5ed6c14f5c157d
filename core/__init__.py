"""The core: data types, plugin contracts and registry, config schema, the episode loop, the run builders (eval,
collect, envs=N, Ray), the run folder and the demonstration pool; it names no plugin. No heavy imports here."""

__version__ = "0.1.0"

"""Episodes and the workers that run them: the episode loop and its runners (one process, envs=N batched
simulators, Ray shards), simulator processes, worker pools, the keyed window, and the collection of
demonstrations."""

"""Scene and action text: the integer encoding of scenes and key actions, parsing an LLM's reply back into
actions, and re-anchoring replies to the scene's objects."""

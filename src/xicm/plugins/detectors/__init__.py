"""Detectors: object names and 3D centres from the cameras (oracle, noisy_oracle, grounding_dino)."""

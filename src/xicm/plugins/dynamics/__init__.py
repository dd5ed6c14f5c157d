"""The dynamics model of X-ICM's demonstration selection (diffusers + torch).

An image-conditioned diffusion model (InstructPix2Pix style) learns to predict a demo's last
front frame from its first front frame and its instruction:

- `images`   frames <-> model tensors at the model's resolution
- `text`     instruction embeddings (all-MiniLM by default, any local transformers encoder)
- `model`    building, saving, loading the UNet; sampling a predicted last frame; one-pass features
- `data`     (first frame, instruction) -> last frame pairs from a pool file, with a held-out split
- `quality`  MSE / SSIM of predicted frames and the comparison picture
- `train`    the `xicm-train-dynamics` job: resumable training with checkpoints

The `dynamics` encoder (src/xicm/plugins/encoders/dynamics.py) turns a trained checkpoint into retrieval
features. Everything here imports torch and diffusers; import it only where it is needed.
"""

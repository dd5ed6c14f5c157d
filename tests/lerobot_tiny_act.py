"""Run INSIDE the lerobot environment: build a tiny randomly initialised ACT policy from a
config (no download, no training), save it as a LeRobot checkpoint, and save the action chunk
the in-memory policy predicts for a fixed observation (the reference a server must reproduce).

    python lerobot_tiny_act.py CHECKPOINT_DIR REFERENCE.npz
"""

import sys
from pathlib import Path

import numpy as np
import torch
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.policies.act.configuration_act import ACTConfig
from lerobot.policies.act.modeling_act import ACTPolicy
from lerobot.policies.factory import make_pre_post_processors

out, reference = Path(sys.argv[1]), sys.argv[2]
SIZE, STATE, ACTION = 32, 16, 8
config = ACTConfig(
    input_features={
        "observation.images.front": PolicyFeature(FeatureType.VISUAL, (3, SIZE, SIZE)),
        "observation.state": PolicyFeature(FeatureType.STATE, (STATE,)),
    },
    output_features={"action": PolicyFeature(FeatureType.ACTION, (ACTION,))},
    chunk_size=5, n_action_steps=5, dim_model=32, n_heads=2, dim_feedforward=64, n_encoder_layers=1,
    n_decoder_layers=1, n_vae_encoder_layers=1, latent_dim=8, pretrained_backbone_weights=None, device="cpu",
)
torch.manual_seed(0)
policy = ACTPolicy(config)
policy.eval()
stats = {
    "observation.images.front": {"mean": torch.full((3, 1, 1), 0.4), "std": torch.full((3, 1, 1), 0.2)},
    "observation.state": {"mean": torch.linspace(-1, 1, STATE), "std": torch.full((STATE,), 0.5)},
    "action": {"mean": torch.linspace(0, 1, ACTION), "std": torch.full((ACTION,), 0.3)},
}
pre, post = make_pre_post_processors(config, dataset_stats=stats)
policy.save_pretrained(out)
pre.save_pretrained(out)
post.save_pretrained(out)

rng = np.random.default_rng(0)
image = rng.integers(0, 256, (SIZE, SIZE, 3), dtype=np.uint8)
state = rng.normal(size=STATE).astype(np.float32)
batch = pre({
    "observation.images.front": torch.from_numpy(image).permute(2, 0, 1).float().unsqueeze(0) / 255.0,
    "observation.state": torch.from_numpy(state).unsqueeze(0),
    "task": ["push the button"],
})
with torch.inference_mode():
    chunk = post(policy.predict_action_chunk(batch))[0].numpy()
np.savez(reference, image=image, state=state, chunk=chunk)

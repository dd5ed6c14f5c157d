"""Serve a LeRobot checkpoint in openpi's websocket dialect. Runs INSIDE the lerobot environment
(xicm's own cannot import lerobot: src/xicm/lerobot/env.py says why), with xicm's serving package
on PYTHONPATH (src/xicm/lerobot/serve.py starts it that way):

    python policy_server.py --checkpoint DIR [--host H] [--port P] [--control-mode S] [--api-key-env VAR]

A request holds LeRobot's own keys: "observation.images.<camera>" (uint8 H x W x 3),
"observation.state" (float vector) and "task" (the instruction); the reply is
{"actions": (chunk_size, action_dim)}, the policy's whole predicted chunk, unnormalised (the
client executes the first policy.chunk_steps_to_execute rows). Nothing is kept between requests.
With --max-batch N > 1, requests arriving together from several connections (xicm-eval envs=N)
go through one forward pass.
"""

import argparse
import logging

import numpy as np
import torch
from lerobot.configs.policies import PreTrainedConfig
from lerobot.policies.factory import get_policy_class, make_pre_post_processors

from xicm.serving.keys import KeyNotSet, key_from_env
from xicm.serving.limits import add_limit_arguments
from xicm.serving.server import PolicyServer


class LeRobotChunks:
    def __init__(self, checkpoint: str, device: str):
        config = PreTrainedConfig.from_pretrained(checkpoint)
        config.pretrained_path = checkpoint
        config.device = device
        self.policy = get_policy_class(config.type).from_pretrained(checkpoint, config=config)
        self.policy.eval()
        self.pre, self.post = make_pre_post_processors(
            config, pretrained_path=checkpoint, preprocessor_overrides={"device_processor": {"device": device}}
        )
        self.config = config
        self.image_keys = list(config.image_features)

    def metadata(self, control_mode: str | None) -> dict:
        meta = {
            "lerobot": {
                "policy_type": self.config.type,
                "image_keys": self.image_keys,
                "state_dim": int(self.config.robot_state_feature.shape[0]) if self.config.robot_state_feature else 0,
                "action_dim": int(self.config.action_feature.shape[0]),
                "chunk_size": int(getattr(self.config, "chunk_size", getattr(self.config, "horizon", 1))),
            }
        }
        if control_mode:
            meta["xicm"] = {"control_mode": control_mode, "observes": True, "observation": "none"}
        return meta

    def infer(self, obs: dict) -> dict:
        return self.infer_batch([obs])[0]

    def infer_batch(self, observations: list[dict]) -> list[dict]:
        batch = {}
        for key in self.image_keys:
            missing = [i for i, obs in enumerate(observations) if key not in obs]
            if missing:
                raise KeyError(f"the request has no '{key}' (the checkpoint reads {', '.join(self.image_keys)})")
            images = [torch.from_numpy(np.ascontiguousarray(obs[key])).permute(2, 0, 1) for obs in observations]
            batch[key] = torch.stack(images).float() / 255.0
        batch["observation.state"] = torch.stack(
            [torch.from_numpy(np.asarray(obs["observation.state"], dtype=np.float32)) for obs in observations])
        batch["task"] = [str(obs.get("task", "")) for obs in observations]
        batch = self.pre(batch)
        with torch.inference_mode():
            chunks = self.post(self.policy.predict_action_chunk(batch))
        return [{"actions": chunk.cpu().numpy().astype(np.float64)} for chunk in chunks]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint", required=True, help="a LeRobot pretrained_model folder (config.json, model.safetensors, processors)")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--control-mode", default=None, help="announce the control mode the checkpoint was trained in (xicm clients then need no policy.control_mode)")
    parser.add_argument("--max-batch", type=int, default=1, help="answer up to N concurrent requests with one forward pass")
    parser.add_argument("--batch-wait-ms", type=float, default=5.0, help="how long a batch waits for more requests")
    add_limit_arguments(parser)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO)
    try:
        api_key = key_from_env(args.api_key_env, "--api-key-env")
    except KeyNotSet as exc:
        parser.exit(2, f"error: {exc}\n")
    served = LeRobotChunks(args.checkpoint, args.device)
    server = PolicyServer(served, args.host, args.port, metadata=served.metadata(args.control_mode),
                          max_batch=args.max_batch, batch_wait_ms=args.batch_wait_ms, api_key=api_key,
                          max_sessions=args.max_sessions, idle_timeout_s=args.idle_timeout_s,
                          key_setting="--api-key-env").start()
    print(f"serving {served.config.type} from {args.checkpoint} on ws://{args.host}:{server.port}", flush=True)
    try:
        server.wait()
    except KeyboardInterrupt:
        server.stop()


if __name__ == "__main__":
    main()

"""Detector "grounding_dino": open-vocabulary boxes from transformers' Grounding DINO, lifted to 3D.

For each configured camera, the caption "name 1 . name 2 . ..." (the task's object names) is
grounded in the camera's RGB picture (all cameras in one batch). A box's score for a name is
the highest sigmoid logit over the name's tokens; each name takes its best box if that score
reaches `box_threshold` and the name's mean token score reaches `text_threshold`. The box
is lifted to 3D with the depth image and the camera parameters: the pixels of the box's
central half with valid depth are back-projected, and the nearer half of them (by depth;
the farther ones are mostly table or background seen around the object) is averaged. Across
cameras the object centre is the per-axis median of the cameras' estimates (robust to one
camera grounding the wrong thing). Names no camera finds are left out, so the prompt says
"<name> not detected" and the episode records them.

Weights are loaded from `model` (a local folder, or a Hugging Face id already in the local
cache; nothing is downloaded during a run).

Options:
    model: "IDEA-Research/grounding-dino-tiny" (default) or a local path.
    box_threshold: 0.35, text_threshold: 0.25 (the upstream defaults).
    cameras: camera names to use (null: every camera of the observation).
    device: "cpu" | "cuda" | ...
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional

import numpy as np

from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Detector
from xicm.core.contracts.schema import between
from xicm.core.contracts.types import CameraFrame, Observation

from .oracle import CAMERAS, backproject

DEFAULT_MODEL = "IDEA-Research/grounding-dino-tiny"


@dataclass
class GroundingDinoOptions:
    model: str = DEFAULT_MODEL
    box_threshold: float = field(default=0.35, metadata=between(0, 1))  # sigmoid scores
    text_threshold: float = field(default=0.25, metadata=between(0, 1))
    cameras: Optional[List[str]] = field(default=None, metadata=CAMERAS)
    device: str = "cpu"


def load_grounding_dino(model: str, device: str = "cpu"):
    """(processor, model) from a local folder or the local HF cache; ConfigError when absent."""
    try:
        from transformers import AutoModelForZeroShotObjectDetection, AutoProcessor
    except ImportError as exc:
        raise ConfigError("detector grounding_dino needs transformers and torch: pip install 'xicm[llm]'") from exc
    try:
        processor = AutoProcessor.from_pretrained(str(model), local_files_only=True)
        net = AutoModelForZeroShotObjectDetection.from_pretrained(str(model), local_files_only=True)
    except (OSError, ValueError) as exc:
        where = "folder" if Path(str(model)).exists() else "checkpoint"
        raise ConfigError(
            f"Grounding DINO {where} '{model}' could not be loaded from this machine ({type(exc).__name__}); "
            f"download it first (huggingface-cli download {DEFAULT_MODEL}) or set detector.model=/path/to/a/local/copy"
        ) from None
    return processor, net.to(device).eval()


def name_token_spans(tokenizer, caption: str, names: list[str]) -> list[list[int]]:
    """Token positions of each name in the caption (from the tokenizer's character offsets)."""
    offsets = tokenizer(caption, return_offsets_mapping=True)["offset_mapping"]
    spans, start = [], 0
    for name in names:
        lo = caption.index(name, start)
        hi = lo + len(name)
        start = hi
        spans.append([i for i, (a, b) in enumerate(offsets) if b > a and a >= lo and b <= hi])
    return spans


def lift_box(frame: CameraFrame, box_xyxy) -> np.ndarray | None:
    """World centre of the object in a pixel box (central half, nearer half of its depths)."""
    h, w = np.asarray(frame.depth).shape
    x0, y0, x1, y1 = (float(v) for v in box_xyxy)
    cx, cy, hw, hh = (x0 + x1) / 2, (y0 + y1) / 2, max((x1 - x0) / 4, 0.5), max((y1 - y0) / 4, 0.5)
    u0, u1 = int(np.clip(np.floor(cx - hw), 0, w - 1)), int(np.clip(np.ceil(cx + hw), 0, w - 1))
    v0, v1 = int(np.clip(np.floor(cy - hh), 0, h - 1)), int(np.clip(np.ceil(cy + hh), 0, h - 1))
    mask = np.zeros((h, w), bool)
    mask[v0 : v1 + 1, u0 : u1 + 1] = True
    depth = np.asarray(frame.depth, dtype=np.float64)
    mask &= np.isfinite(depth) & (depth > 0)
    if not mask.any():
        return None
    mask &= depth <= np.median(depth[mask])
    points = backproject(frame, mask)
    return points.mean(axis=0) if len(points) else None


class GroundingDinoDetector(Detector):
    def __init__(self, options: GroundingDinoOptions | None = None):
        o = options if options is not None else GroundingDinoOptions()
        self.model_name = o.model
        self.box_threshold, self.text_threshold = o.box_threshold, o.text_threshold
        self.cameras = None if o.cameras is None else list(o.cameras)
        self.device = o.device
        self.processor, self.model = load_grounding_dino(self.model_name, self.device)
        self.seconds: list[float] = []  # per detect() call, for benchmarks

    def detect(self, obs: Observation, names: list[str]) -> dict[str, tuple[float, float, float]]:
        import torch

        t0 = time.perf_counter()
        names = [n for n in dict.fromkeys(names)]
        if not names:
            return {}
        cameras = list(obs.cameras) if self.cameras is None else self.cameras
        missing = [c for c in cameras if c not in obs.cameras]
        if missing:
            raise KeyError(f"grounding_dino: camera(s) {', '.join(missing)} not in the observation; available: {', '.join(obs.cameras)}")
        frames = [obs.cameras[c] for c in cameras]
        caption = " . ".join(n.lower() for n in names) + " ."
        spans = name_token_spans(self.processor.tokenizer, caption, [n.lower() for n in names])
        inputs = self.processor(images=[f.rgb for f in frames], text=[caption] * len(frames), return_tensors="pt")
        with torch.no_grad():
            out = self.model(**{k: v.to(self.device) for k, v in inputs.items()})
        probs = out.logits.sigmoid().cpu().numpy()  # (cameras, queries, text tokens)
        boxes = out.pred_boxes.cpu().numpy()  # (cameras, queries, 4): cx, cy, w, h in [0, 1]
        estimates: dict[str, list[np.ndarray]] = {n: [] for n in names}
        for c, frame in enumerate(frames):
            h, w = np.asarray(frame.depth).shape
            for name, span in zip(names, spans):
                if not span:
                    continue
                per_query = probs[c][:, span]  # (queries, name tokens)
                q = int(np.argmax(per_query.max(axis=1)))
                if per_query[q].max() < self.box_threshold or per_query[q].mean() < self.text_threshold:
                    continue
                cx, cy, bw, bh = boxes[c, q]
                xyz = lift_box(frame, ((cx - bw / 2) * w, (cy - bh / 2) * h, (cx + bw / 2) * w, (cy + bh / 2) * h))
                if xyz is not None:
                    estimates[name].append(xyz)
        result = {}
        for name in names:
            if estimates[name]:
                centre = np.median(np.stack(estimates[name]), axis=0)
                result[name] = (float(centre[0]), float(centre[1]), float(centre[2]))
        self.seconds.append(time.perf_counter() - t0)
        return result


@hookimpl
def register_detectors(register):
    register("grounding_dino", GroundingDinoDetector, options=GroundingDinoOptions)

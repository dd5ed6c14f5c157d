"""`xicm-train-dynamics`: train the dynamics model on a pool's (first frame, instruction) ->
last frame pairs with the diffusion MSE loss (on velocity, noise or target, per
`dynamics_model.prediction`), resumably.

Every `checkpoint_every` steps a checkpoint `checkpoints/step-NNNNNN/` is written (unet/ and
scheduler/ in diffusers' save_pretrained format, dynamics.json, training_state.pt with the
optimizer); a re-run of the same command continues from the newest one, and because each
step's batch, noise and timesteps are drawn from (seed, step), a resumed run ends with the same
weights as an uninterrupted one. At the end `final/` holds the model the `dynamics` encoder
loads, `heldout.json` the prediction quality on held-out demos (against copying the first
frame) and `heldout.png` predicted vs real last frames.
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F
from omegaconf import DictConfig, OmegaConf

from xicm.core.results.atomic import write_atomic, write_dir_atomic
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.schema import check_config
from xicm.core.results.tracking import Tracker
from xicm.plugins.dynamics import model as dm
from xicm.plugins.dynamics.config_schema import TrainDynamicsConfig
from xicm.plugins.dynamics.data import Pairs, load_pairs, split
from xicm.plugins.dynamics.images import to_model, to_uint8
from xicm.plugins.dynamics.quality import comparison_picture, mse, ssim
from xicm.plugins.dynamics.text import embed_unique, text_encoder

STATE_FILE = "training_state.pt"
# meta keys that must match for a checkpoint to be resumed
RESUME_KEYS = ("model", "text_encoder", "dataset", "num_train_timesteps", "seed", "batch_size", "target", "target_scale")


def _checkpoints(folder: Path) -> list[tuple[int, Path]]:
    found = []
    for p in folder.glob("step-*"):
        if p.is_dir() and p.name[5:].isdigit() and (p / STATE_FILE).exists() and (p / dm.META_FILE).exists():
            found.append((int(p.name[5:]), p))
    return sorted(found)


def _lr(step: int, base: float, warmup: int) -> float:
    return base * min(1.0, (step + 1) / max(1, warmup))


def _step_batch(seed: int, step: int, n: int, batch: int, shape: tuple[int, ...], timesteps: int):
    """Indices, noise and timesteps of one step, a function of (seed, step) only."""
    g = torch.Generator().manual_seed(int(seed) * 1_000_003 + int(step))
    idx = torch.randint(0, n, (batch,), generator=g)
    noise = torch.randn((batch, *shape), generator=g)
    t = torch.randint(0, timesteps, (batch,), generator=g)
    return idx, noise, t


def run_training(cfg: DictConfig) -> dict[str, Any]:
    check_config(cfg, TrainDynamicsConfig)  # a bad value stops here, not after the training
    train_cfg, model_cfg = cfg.train, OmegaConf.to_container(cfg.dynamics_model, resolve=True)
    if train_cfg.threads:
        torch.set_num_threads(int(train_cfg.threads))
    res = int(model_cfg["resolution"])
    tasks = list(cfg.tasks) if cfg.tasks else None
    pairs = load_pairs(cfg.pool_path, tasks)
    train_set, heldout = split(pairs, int(train_cfg.heldout_every))
    text_spec = OmegaConf.to_container(cfg.text_encoder, resolve=True)
    text = text_encoder(text_spec)
    context, _ = embed_unique(text, train_set.instructions)
    first, last = to_model(train_set.first, res), to_model(train_set.last, res)
    target = str(model_cfg["target"])
    meta = {
        "target": target,
        "target_scale": round(1.0 / max(float((last - first).std()), 1e-3), 4),
        "format": "xicm-dynamics",
        "resolution": res,
        "model": model_cfg,
        "text_encoder": text_spec,
        "text_encoder_key": text.key,
        "num_train_timesteps": int(train_cfg.num_train_timesteps),
        "dataset": train_set.fingerprint(),
        "pool_path": str(cfg.pool_path),
        "train_demos": len(train_set),
        "heldout_demos": len(heldout),
        "heldout_every": int(train_cfg.heldout_every),
        "seed": int(train_cfg.seed),
        "batch_size": int(train_cfg.batch_size),
    }
    out = Path(cfg.out_dir)
    ckpt_root = out / "checkpoints"
    scheduler = dm.train_scheduler(meta)
    unet, opt, step, seconds = _start(meta, ckpt_root, text.dim, train_cfg)
    total = int(train_cfg.steps)
    tracker = Tracker(
        mode=cfg.tracking.mode,
        project=cfg.tracking.project,
        run_name=str(cfg.run_name),
        out_dir=str(out),
        config=OmegaConf.to_container(cfg, resolve=True),
        tags=["train_dynamics"],
    )
    print(
        f"[train-dynamics] {len(train_set)} training / {len(heldout)} held-out demos of {len(set(pairs.tasks))} tasks, "
        f"{sum(p.numel() for p in unet.parameters()) / 1e6:.2f}M parameters, {res}x{res}, "
        f"step {step} -> {total}" + (" (resumed)" if step else "")
    )
    try:
        run = TrainingRun(unet, opt, scheduler, first, last, context, meta, train_cfg, ckpt_root, tracker, bool(cfg.progress))
        step, seconds = _train_loop(run, step, total, seconds)
        unet.eval()
        write_dir_atomic(out / "final", lambda d: dm.save_checkpoint(d, unet, scheduler, {**meta, "step": step, "train_seconds": seconds}))
        quality = evaluate_heldout(unet, scheduler.config, meta, heldout, text, res, cfg.evaluation, out)
        summary = {"step": step, "train_seconds": round(seconds, 1), "final": str(out / "final"), **quality}
        write_atomic(out / "heldout.json", json.dumps(summary, indent=2))
        tracker.summary({f"heldout/{k}": v for k, v in flat_figures(quality).items()})
        tracker.log_images([out / "heldout.png"] if (out / "heldout.png").exists() else [])
    finally:
        note = tracker.finish()
        if note:
            print(note)
    return summary


def _start(meta: dict[str, Any], ckpt_root: Path, text_dim: int, train_cfg) -> tuple[Any, Any, int, float]:
    """A fresh model, or the newest compatible checkpoint with its optimizer state."""
    found = _checkpoints(ckpt_root)
    if found:
        step, folder = found[-1]
        old = dm.read_meta(folder)
        changed = [k for k in RESUME_KEYS if old.get(k) != meta.get(k)]
        if changed:
            raise ConfigError(
                f"{ckpt_root} holds checkpoints of a different training setup ({', '.join(changed)} changed); "
                "choose another out_dir or delete that folder"
            )
        unet = dm.load_unet(folder)
        unet.train()
        opt = _optimizer(unet, train_cfg)
        state = torch.load(folder / STATE_FILE, weights_only=True)
        opt.load_state_dict(state["optimizer"])
        return unet, opt, step, float(state.get("seconds", 0.0))
    torch.manual_seed(int(train_cfg.seed))
    unet = dm.build_unet(meta["model"], text_dim)
    unet.train()
    return unet, _optimizer(unet, train_cfg), 0, 0.0


def _optimizer(unet, train_cfg):
    return torch.optim.AdamW(unet.parameters(), lr=float(train_cfg.lr), weight_decay=float(train_cfg.weight_decay))


class LossLog:
    """train_log.csv (step, loss, lr): rows past the step a run resumes from are dropped."""

    def __init__(self, path: Path, resume_step: int):
        rows = []
        if path.exists():
            with open(path, encoding="utf-8") as f:
                rows = [line for line in f.read().splitlines()[1:] if line and int(line.split(",")[0]) <= resume_step]
        path.parent.mkdir(parents=True, exist_ok=True)
        self._f = open(path, "w", encoding="utf-8")
        self._f.write("\n".join(["step,loss,lr", *rows]) + "\n")
        self._f.flush()

    def add(self, step: int, loss: float, lr: float) -> None:
        self._f.write(f"{step},{loss:.6f},{lr:.6g}\n")

    def flush(self) -> None:
        self._f.flush()

    def close(self) -> None:
        self._f.close()


@dataclass
class TrainingRun:
    """Everything a training loop step needs."""

    unet: Any
    opt: Any
    scheduler: Any
    first: torch.Tensor
    last: torch.Tensor
    context: torch.Tensor
    meta: dict[str, Any]
    cfg: Any  # the `train` config group
    ckpt_root: Path
    tracker: Tracker
    progress: bool


def _train_loop(run: TrainingRun, step: int, total: int, seconds: float) -> tuple[int, float]:
    log = LossLog(run.ckpt_root.parent / "train_log.csv", step)
    try:
        return _steps(run, step, total, seconds, log)
    finally:
        log.close()


def _steps(run: TrainingRun, step: int, total: int, seconds: float, log: LossLog) -> tuple[int, float]:
    bar = None
    if run.progress:
        from tqdm import tqdm

        bar = tqdm(total=total, initial=step, desc="train-dynamics", unit="step", dynamic_ncols=True)
    meta, train_cfg, unet, opt = run.meta, run.cfg, run.unet, run.opt
    every = max(1, int(train_cfg.checkpoint_every))
    log_every = max(1, int(train_cfg.log_every))
    shape = tuple(run.last.shape[1:])
    running = None
    started = time.perf_counter() - seconds
    while step < total:
        idx, noise, t = _step_batch(meta["seed"], step, len(run.first), meta["batch_size"], shape, meta["num_train_timesteps"])
        first = run.first[idx]
        clean = dm.encode_target(first, run.last[idx], meta)
        noisy = run.scheduler.add_noise(clean, noise, t)
        pred = unet(torch.cat([noisy, first], dim=1), t, encoder_hidden_states=run.context[idx]).sample
        loss = F.mse_loss(pred, dm.loss_target(run.scheduler, clean, noise, t))
        for group in opt.param_groups:
            group["lr"] = _lr(step, float(train_cfg.lr), int(train_cfg.warmup_steps))
        opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(unet.parameters(), 1.0)
        opt.step()
        step += 1
        value = loss.item()
        running = value if running is None else 0.98 * running + 0.02 * value
        log.add(step, value, opt.param_groups[0]["lr"])
        if step % log_every == 0:
            run.tracker.log({"train/loss": value, "train/loss_smoothed": running, "train/lr": opt.param_groups[0]["lr"], "train/step": step})
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"loss {running:.4f}")
        if step % every == 0 or step == total:
            seconds = time.perf_counter() - started
            _save_checkpoint(run.ckpt_root, unet, run.scheduler, opt, meta, step, seconds, int(train_cfg.keep_checkpoints))
            log.flush()
            if bar is None:
                print(f"[train-dynamics] step {step}/{total} loss {running:.4f} ({seconds / 60:.1f} min)", flush=True)
    if bar is not None:
        bar.close()
    return step, time.perf_counter() - started


def _save_checkpoint(root: Path, unet, scheduler, opt, meta, step: int, seconds: float, keep: int) -> None:
    def write(folder: Path) -> None:
        dm.save_checkpoint(folder, unet, scheduler, {**meta, "step": step, "train_seconds": seconds})
        torch.save({"optimizer": opt.state_dict(), "step": step, "seconds": seconds}, folder / STATE_FILE)

    root.mkdir(parents=True, exist_ok=True)
    write_dir_atomic(root / f"step-{step:06d}", write)
    for _old_step, folder in _checkpoints(root)[: -max(1, keep)]:
        shutil.rmtree(folder, ignore_errors=True)


def evaluate_heldout(unet, scheduler_config, meta: dict[str, Any], heldout: Pairs, text, res: int, ev, out: Path) -> dict[str, Any]:
    """MSE and SSIM of last frames sampled with each of `ev.sample_steps` DDIM step counts vs the
    real ones, and of the first frame as a guess; heldout.png shows them side by side."""
    if len(heldout) == 0:
        print("[train-dynamics] no held-out demos (train.heldout_every < 2 or too few episodes): no quality figures")
        return {"heldout_demos": 0}
    context, _ = embed_unique(text, heldout.instructions)
    first = to_model(heldout.first, res)
    real, copy = to_uint8(to_model(heldout.last, res)), to_uint8(first)
    batch = int(ev.batch_size)
    result: dict[str, Any] = {
        "heldout_demos": len(heldout),
        "mse_copy_first": float(mse(copy, real).mean()),
        "ssim_copy_first": float(ssim(copy, real).mean()),
        "predicted": {},
    }
    columns = [("first", copy)]
    for steps in _step_counts(ev.sample_steps):
        started = time.perf_counter()
        predicted = torch.cat(
            [
                dm.predict_last(unet, scheduler_config, meta, first[i : i + batch], context[i : i + batch], steps, int(ev.seed))
                for i in range(0, len(first), batch)
            ]
        )
        guess = to_uint8(predicted)
        result["predicted"][str(steps)] = {
            "mse": float(mse(guess, real).mean()),
            "ssim": float(ssim(guess, real).mean()),
            "seconds_per_sample": round((time.perf_counter() - started) / len(first), 4),
        }
        columns.append((f"predicted, {steps} step{'s' if steps > 1 else ''}", guess))
        print(
            f"[train-dynamics] held-out ({len(heldout)} demos, {steps} sampling steps): MSE {result['predicted'][str(steps)]['mse']:.5f} "
            f"(copy first frame {result['mse_copy_first']:.5f}), SSIM {result['predicted'][str(steps)]['ssim']:.3f} "
            f"(copy first frame {result['ssim_copy_first']:.3f})"
        )
    # one picture row per task (its first held-out demo), up to evaluation.num_images
    rows = list(dict.fromkeys(heldout.tasks))[: int(ev.num_images)]
    pick = [heldout.tasks.index(t) for t in rows]
    columns.append(("real last", real))
    comparison_picture(out / "heldout.png", [(name, images[pick]) for name, images in columns], [heldout.demo_ids[i] for i in pick])
    print(f"[train-dynamics] picture: {out / 'heldout.png'}")
    return result


def _step_counts(value) -> list[int]:
    """evaluation.sample_steps (checked by the schema): one count or a list of them."""
    return [int(v) for v in (value if OmegaConf.is_list(value) or isinstance(value, (list, tuple)) else [value])]


def flat_figures(quality: dict[str, Any]) -> dict[str, float]:
    """heldout.json's figures as flat numeric keys (for wandb's summary)."""
    flat = {k: v for k, v in quality.items() if isinstance(v, (int, float))}
    for steps, figures in quality.get("predicted", {}).items():
        flat.update({f"{name}_{steps}_steps": v for name, v in figures.items()})
    return flat

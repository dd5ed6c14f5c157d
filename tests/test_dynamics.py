"""The dynamics model, its training job and the dynamics encoder/retriever, on a tiny
synthetic pool and a tiny model (seconds)."""

from __future__ import annotations

import csv
import json
from types import SimpleNamespace

import numpy as np
import pytest
from hydra import compose, initialize_config_module

pytest.importorskip("diffusers")
import torch  # noqa: E402

from dynamics_fixtures import TASKS, frame, write_pool  # noqa: E402
from xicm.core.results.dataset import load_pool  # noqa: E402
from xicm.core.contracts.errors import ConfigError  # noqa: E402
from xicm.core.assembly.plugins import get_registry  # noqa: E402
from xicm.core.contracts.types import Query  # noqa: E402
from xicm.plugins.dynamics.train import run_training  # noqa: E402
from xicm.plugins.encoders.dynamics import DynamicsEncoder, resolve_checkpoint  # noqa: E402
from xicm.plugins.encoders.dynamics import DynamicsEncoderOptions  # noqa: E402
from xicm.plugins.retrievers.dynamics import DynamicsRetriever  # noqa: E402
from xicm.plugins.retrievers.similarity import SimilarityOptions  # noqa: E402


def _cfg(pool, out, *extra):
    overrides = [
        f"pool_path={pool}",
        f"out_dir={out}",
        "dynamics_model=tiny",
        "train.batch_size=8",
        "train.lr=2e-3",
        "train.warmup_steps=5",
        "train.log_every=1",
        "train.heldout_every=6",
        "train.threads=1",
        "evaluation.sample_steps=[1,4]",
        "evaluation.num_images=2",
        "tracking.mode=disabled",
        "progress=false",
        *extra,
    ]
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("train_dynamics", overrides=overrides)


@pytest.fixture(scope="module")
def pool(tmp_path_factory):
    return write_pool(tmp_path_factory.mktemp("dyn") / "tiny.h5")


@pytest.fixture(scope="module")
def trained(pool, tmp_path_factory):
    out = tmp_path_factory.mktemp("model")
    summary = run_training(_cfg(pool, out, "train.steps=80", "train.checkpoint_every=40"))
    return out, summary


def test_the_training_loss_goes_down(trained):
    out, _ = trained
    losses = [float(r["loss"]) for r in csv.DictReader(open(out / "train_log.csv"))]
    assert len(losses) == 80
    assert np.mean(losses[-15:]) < 0.7 * np.mean(losses[:15])


def test_training_writes_a_diffusers_checkpoint_quality_figures_and_a_picture(trained):
    out, summary = trained
    from diffusers import UNet2DConditionModel

    unet = UNet2DConditionModel.from_pretrained(out / "final" / "unet")
    assert unet.config.in_channels == 6 and unet.config.sample_size == 16
    assert (out / "final" / "scheduler" / "scheduler_config.json").exists()
    figures = json.loads((out / "heldout.json").read_text())
    assert figures["heldout_demos"] == 2  # episode 5 of each task (heldout_every=6)
    assert sorted(figures["predicted"]) == ["1", "4"]
    for key in ("mse_copy_first", "ssim_copy_first"):
        assert np.isfinite(figures[key])
    for by_steps in figures["predicted"].values():
        assert np.isfinite(by_steps["mse"]) and np.isfinite(by_steps["ssim"]) and by_steps["seconds_per_sample"] > 0
    assert figures["mse_copy_first"] > 0  # the square moves
    assert (out / "heldout.png").stat().st_size > 1000
    assert summary["step"] == 80
    assert [p.name for p in sorted((out / "checkpoints").iterdir())] == ["step-000040", "step-000080"]


@pytest.mark.parametrize("prediction", ["epsilon", "sample"])  # v_prediction: the default, trained above
def test_every_prediction_type_trains_and_is_recorded_in_the_checkpoint(pool, tmp_path, prediction):
    run_training(_cfg(pool, tmp_path, "train.steps=60", "train.checkpoint_every=60", f"dynamics_model.prediction={prediction}"))
    losses = [float(r["loss"]) for r in csv.DictReader(open(tmp_path / "train_log.csv"))]
    assert np.mean(losses[-15:]) < 0.8 * np.mean(losses[:15])
    config = json.loads((tmp_path / "final" / "scheduler" / "scheduler_config.json").read_text())
    assert config["prediction_type"] == prediction
    with pytest.raises(ConfigError, match="v_prediction"):
        run_training(_cfg(pool, tmp_path / "bad", "train.steps=1", "dynamics_model.prediction=x0"))
    with pytest.raises(ConfigError, match="sample_steps"):
        run_training(_cfg(pool, tmp_path / "bad", "train.steps=1", "evaluation.sample_steps=[1,0]"))
    assert not (tmp_path / "bad" / "checkpoints").exists()  # both refused before any training


class _ConstantClean(torch.nn.Module):
    """A stand-in UNet whose output is always the same clean target (prediction type `sample`)."""

    def __init__(self, clean: torch.Tensor):
        super().__init__()
        self.clean = clean
        self.unused = torch.nn.Parameter(torch.zeros(1))  # predict_last reads the device from a parameter

    def forward(self, x, t, encoder_hidden_states):
        return SimpleNamespace(sample=self.clean.expand(len(x), -1, -1, -1))


def test_sampling_can_predict_changes_as_large_as_the_pixel_range():
    """Regression: diffusers' default clipping of the clean estimate to [-1, 1] applied to the scaled
    residual capped every predicted change at 1/target_scale of the pixel range."""
    from xicm.plugins.dynamics import model as dm

    meta = {"target": "residual", "target_scale": 11.0, "num_train_timesteps": 1000, "model": {"prediction": "sample"}}
    config = dict(dm.train_scheduler(meta).config)
    first = torch.full((2, 3, 4, 4), -0.5)
    unet = _ConstantClean(dm.encode_target(torch.zeros(1, 3, 4, 4), torch.ones(1, 3, 4, 4), meta))
    for scheduler_config in (config, {**config, "clip_sample_range": 1.0}):  # the latter: checkpoints saved before the fix
        last = dm.predict_last(unet, scheduler_config, meta, first, torch.zeros(2, 1, 8), steps=4)
        assert torch.allclose(last, torch.full_like(last, 0.5), atol=1e-4)


def test_a_resumed_training_ends_with_the_weights_of_an_uninterrupted_one(pool, tmp_path):
    whole, parts = tmp_path / "whole", tmp_path / "parts"
    run_training(_cfg(pool, whole, "train.steps=8", "train.checkpoint_every=4", "train.heldout_every=0"))
    run_training(_cfg(pool, parts, "train.steps=4", "train.checkpoint_every=4", "train.heldout_every=0"))
    summary = run_training(_cfg(pool, parts, "train.steps=8", "train.checkpoint_every=4", "train.heldout_every=0"))
    assert summary["step"] == 8
    from safetensors.torch import load_file

    wa = load_file(whole / "final" / "unet" / "diffusion_pytorch_model.safetensors")
    wb = load_file(parts / "final" / "unet" / "diffusion_pytorch_model.safetensors")
    assert wa.keys() == wb.keys() and all(torch.equal(wa[k], wb[k]) for k in wa)


def test_resuming_with_another_model_is_refused(pool, tmp_path):
    run_training(_cfg(pool, tmp_path, "train.steps=2", "train.checkpoint_every=2", "train.heldout_every=0"))
    with pytest.raises(ConfigError, match="different training setup"):
        run_training(_cfg(pool, tmp_path, "train.steps=4", "dynamics_model.block_out_channels=[8,8]", "train.heldout_every=0"))


def test_features_are_deterministic_and_depend_on_seed_and_text(trained):
    out, _ = trained
    img = frame(TASKS["slide_left"][1], 10, 4)
    items = [(img, TASKS["slide_left"][0]), (img, "push the red block forward")]
    a = DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=3)).encode(items)
    b = DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=3)).encode(items)
    assert a.shape == (2, 3 * 16 * 16 + 384) and np.array_equal(a, b)
    assert not np.allclose(a[0], a[1])  # same frame, other instruction
    assert not np.allclose(a, DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=3, seed=1)).encode(items))
    assert np.allclose(np.linalg.norm(a, axis=1), 1.0, atol=1e-5)
    one_pass = DynamicsEncoder(DynamicsEncoderOptions(str(out), mode="unet_features")).encode(items)
    assert np.array_equal(one_pass, DynamicsEncoder(DynamicsEncoderOptions(str(out), mode="unet_features")).encode(items))
    assert not np.allclose(one_pass[0], one_pass[1])


def test_the_xicm_feature_is_the_raw_predicted_final_frame_without_text(trained):
    out, _ = trained
    img = frame(TASKS["slide_left"][1], 10, 4)
    items = [(img, TASKS["slide_left"][0]), (img, "push the red block forward")]
    raw = DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=2, visual="final", text_weight=0.0, normalise=False)).encode(items)
    unit = DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=2, visual="final", text_weight=0.0)).encode(items)
    assert raw.shape == (2, 3 * 16 * 16) and not np.allclose(np.linalg.norm(raw, axis=1), 1.0)
    # the normalised feature's visual part is the raw one scaled to unit length, its text part weighs 0
    assert np.allclose(unit[:, : raw.shape[1]], raw / np.linalg.norm(raw, axis=1, keepdims=True), atol=1e-6)
    assert np.allclose(unit[:, raw.shape[1] :], 0)
    with pytest.raises(ConfigError, match="text_weight must be 0"):
        DynamicsEncoder(DynamicsEncoderOptions(str(out), normalise=False))
    keys = {DynamicsEncoder(DynamicsEncoderOptions(str(out), text_weight=0.0, normalise=n)).cache_key() for n in (True, False)}
    assert len(keys) == 2


def test_the_feature_cache_is_reused_and_invalidated_when_the_checkpoint_changes(pool, tmp_path):
    out = tmp_path / "model"
    run_training(_cfg(pool, out, "train.steps=2", "train.checkpoint_every=2", "train.heldout_every=0"))
    demos = load_pool(pool)
    first = DynamicsRetriever(SimilarityOptions(cache_dir=str(tmp_path / "cache")), encoder=DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=2)))
    first.prepare(demos)
    again = DynamicsRetriever(SimilarityOptions(cache_dir=str(tmp_path / "cache")), encoder=DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=2)))
    again.prepare(demos)
    assert (first.cache_hit, again.cache_hit) == (False, True) and again.cache_path == first.cache_path

    run_training(_cfg(pool, out, "train.steps=4", "train.checkpoint_every=2", "train.heldout_every=0"))
    retrained = DynamicsRetriever(SimilarityOptions(cache_dir=str(tmp_path / "cache")), encoder=DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=2)))
    retrained.prepare(demos)
    assert retrained.cache_hit is False and retrained.cache_path != first.cache_path


def test_retrieval_returns_k_distinct_demos_best_first(trained, pool, tmp_path):
    out, _ = trained
    demos = load_pool(pool)
    retriever = DynamicsRetriever(SimilarityOptions(cache_dir=str(tmp_path)), encoder=DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=3)))
    retriever.prepare(demos)
    text, colour, start, _ = TASKS["slide_right"]
    query = Query(task="slide_right", instruction=text, objects={}, front_rgb=frame(colour, start, 6))
    chosen = retriever.select(query, demos, 5, np.random.default_rng(0))
    scores = [s for _, s in chosen]
    assert len({d.demo_id for d, _ in chosen}) == 5
    assert scores == sorted(scores, reverse=True)
    others = DynamicsRetriever(SimilarityOptions(cache_dir=str(tmp_path), exclude_same_task=True), encoder=DynamicsEncoder(DynamicsEncoderOptions(str(out), steps=3)))
    assert all(d.task == "slide_left" for d, _ in others.select(query, demos, 3, np.random.default_rng(0)))


def test_missing_models_and_bad_options_say_what_to_do(tmp_path, pool):
    with pytest.raises(ConfigError, match="xicm-train-dynamics"):
        resolve_checkpoint(tmp_path)
    run_training(_cfg(pool, tmp_path / "m", "train.steps=2", "train.checkpoint_every=2", "train.heldout_every=0"))
    import shutil

    shutil.rmtree(tmp_path / "m" / "final")
    with pytest.raises(ConfigError, match="step-000002"):
        resolve_checkpoint(tmp_path / "m")
    with pytest.raises(ConfigError, match="^encoder.mode must be one of predicted_frame, unet_features, not 'pixels'$"):
        get_registry().create("encoder", {"name": "dynamics", "checkpoint": str(tmp_path / "m"), "mode": "pixels"})
    from xicm.plugins.encoders.minilm import MiniLMEncoder

    with pytest.raises(ConfigError, match="encoder=dynamics"):
        DynamicsRetriever(SimilarityOptions(), encoder=MiniLMEncoder())


def test_a_transformers_text_encoder_from_a_local_folder(tmp_path):
    """The `transformers` text kind (e.g. SD-2's CLIP text encoder), with a tiny random BERT."""
    from transformers import BertConfig, BertModel, BertTokenizer

    from xicm.plugins.dynamics.text import text_encoder

    words = ["[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]", "open", "close", "the", "drawer", "jar"]
    (tmp_path / "vocab.txt").write_text("\n".join(words) + "\n")
    BertTokenizer(str(tmp_path / "vocab.txt")).save_pretrained(tmp_path)
    torch.manual_seed(0)
    BertModel(BertConfig(vocab_size=len(words), hidden_size=32, num_hidden_layers=1, num_attention_heads=2, intermediate_size=64)).save_pretrained(tmp_path)
    enc = text_encoder({"kind": "transformers", "path": str(tmp_path), "max_length": 12})
    context, feats = enc.encode(["open the drawer", "close the jar"])
    assert context.shape == (2, 12, 32) and feats.shape == (2, 32)
    assert not np.allclose(feats[0], feats[1])
    with pytest.raises(ConfigError, match="kind"):
        text_encoder({"kind": "clip-magic"})


@pytest.mark.slow
@pytest.mark.subprocess
def test_the_leave_one_task_out_benchmark_reports_sources_and_agreement(trained, pool, tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    out, _ = trained
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "retrieval_loto.py"
    report = tmp_path / "loto.json"
    args = ["--pool", str(pool), "--checkpoint", str(out), "--k", "3", "--steps", "2", "--heldout-every", "6"]
    args += ["--retrievers", "dynamics,dynamics_change,dynamics_xicm,random", "--cache-dir", str(tmp_path / "cache"), "--json", str(report)]
    subprocess.run([sys.executable, str(script), *args], check=True, capture_output=True, timeout=300)
    results = json.loads(report.read_text())["results"]
    for name in ("dynamics", "dynamics_change", "dynamics_xicm", "random"):
        # own task excluded: every retrieved demo comes from the other task, whose square slides the other way
        assert set(results[name]["sources"]["slide_left"]) == {"slide_right"}
        assert results[name]["gripper_pattern_match_percent"] == 100.0  # one key action, gripper open, in both tasks
        assert results[name]["change_cosine"] <= 0.0  # the squares slide in opposite directions

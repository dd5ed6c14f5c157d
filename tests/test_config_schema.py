"""Typed config schemas: every family of bad value stops at start with one sentence naming the
key, what is allowed and the value (through the CLI's main, in this process, for one value per family)."""

import dataclasses
import inspect
import re
from pathlib import Path

import pytest
from hydra import compose, initialize_config_module

from cli_in_process import run_main
from xicm.core.assembly import build, checks
from xicm.core.assembly.config_schema import XicmConfig
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import DEFAULT_PLUGINS, get_registry
from xicm.core.contracts.schema import check_config, check_overrides

CONF = Path(__file__).resolve().parents[1] / "src/xicm/conf"
PLUGIN_GROUPS = ["simulator", "detector", "encoder", "retriever", "prompt", "llm", "policy"]
SEEDS = "a non-empty list of distinct integers from 0 to 4294967295, e.g. [0,1,2]"
IMAGE_SIZE = (
    "an integer from 1 to 4096, or [height, width] of two such integers, or a mapping from camera names "
    "(front, left_shoulder, right_shoulder, overhead, wrist) to either"
)
TOP_KEYS = [f.name for f in dataclasses.fields(XicmConfig)]


def _compose(overrides=()):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("config", overrides=list(overrides))


@pytest.fixture
def cli(monkeypatch, capsys):
    """xicm-<command> with these arguments, in this process (cli_in_process.py)."""
    from xicm.core.assembly import cli as commands

    def run(command, *args, cwd):
        main = getattr(commands, f"{command}_main")
        return run_main(main, f"xicm-{command}", *args, cwd=cwd, monkeypatch=monkeypatch, capsys=capsys)

    return run


def _one_sentence(out) -> str:
    """The CLI's whole stderr, which must be exactly one `xicm: error:` line (exit status 2)."""
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr
    return out.stderr.strip()


# ------------------------------------------------------------------ through the real CLI
@pytest.mark.parametrize(
    "args, sentence",
    [
        (["seeds=abc"], f"seeds must be {SEEDS}, not 'abc'"),  # a type Hydra would also reject, in four lines
        (["episodes=-1"], "episodes must be an integer >= 1, not -1"),  # a range of the config's own keys
        (["policy=oracle", "max_steps=0"], "max_steps must be an integer >= 1, not 0"),
        (["tracking.mode=bogus"], "tracking.mode must be one of offline, online, disabled, not 'bogus'"),  # a choice
        (["-m", "episodes=2,abc"], "episodes must be an integer >= 1, not 'abc'"),  # each value of a sweep
        (["policy.k=0"], "policy.k must be an integer >= 1, not 0"),  # a plugin's range (the policy's)
        (["policy=oracle", "simulator.image_size=0"], f"simulator.image_size must be {IMAGE_SIZE}, not 0"),
        (["+llm.k=3"], "unknown option llm.k of llm 'nearest_demo'; available: demo_rank, grammar, reply, stop_at_action_list"),  # an option it does not take
        (["retriever.exclude_same_task=maybe"], "retriever.exclude_same_task must be true or false, not 'maybe'"),
        (["episode=3"], f"unknown key episode (did you mean episodes?); the config has: {', '.join(TOP_KEYS)}"),
    ],
)
def test_xicm_eval_stops_at_start_with_one_sentence(cli, tmp_path, args, sentence):
    out = cli("eval", f"paths.data={tmp_path}", *args, cwd=tmp_path)
    assert _one_sentence(out) == f"xicm: error: {sentence}"
    assert not list(tmp_path.rglob("run.json"))  # nothing was run


def test_xicm_collect_stops_at_start_with_one_sentence(cli, tmp_path):
    out = cli("collect", f"paths.data={tmp_path}", "collect.workers=many", cwd=tmp_path)
    assert _one_sentence(out) == "xicm: error: collect.workers must be 'auto' or an integer >= 1, not 'many'"


# ------------------------------------------------------------------ the config's own keys
@pytest.mark.parametrize(
    "override, sentence",
    [
        ("seeds=[-1]", f"seeds must be {SEEDS}, not [-1]"),
        ("seeds=[0,0]", f"seeds must be {SEEDS}, not [0, 0]"),
        ("seeds=[]", f"seeds must be {SEEDS}, not []"),
        ("seeds=[4294967296]", f"seeds must be {SEEDS}, not [4294967296]"),  # would repeat seed 0's scenes
        ("episodes=0", "episodes must be an integer >= 1, not 0"),
        ("collect.demos_per_task=0", "collect.demos_per_task must be an integer >= 1, not 0"),
        ("collect.seed=-1", "collect.seed must be an integer from 0 to 4294967295, not -1"),
        ("collect.max_attempts_factor=0.5", "collect.max_attempts_factor must be a number >= 1, not 0.5"),
        ("collect.workers=0", "collect.workers must be 'auto' or an integer >= 1, not 0"),
        ("collect.workers=many", "collect.workers must be 'auto' or an integer >= 1, not 'many'"),
        ("video.fps=0", "video.fps must be a number > 0, not 0"),
        ("video.fps=fast", "video.fps must be a number > 0, not 'fast'"),  # int or float: an Any field, checked by its rule
        ("video.every=0", "video.every must be an integer >= 1, not 0"),
        ("video.camera=''", "video.camera must be a camera name (a non-empty string), not ''"),
        ("shards.backend=dask", "shards.backend must be one of local, ray, not 'dask'"),
        ("shards.workers=0", "shards.workers must be an integer >= 1, not 0"),
        ("shards.cpus_per_worker=0", "shards.cpus_per_worker must be a number > 0, not 0"),
        ("benchmark.tasks=[]", "benchmark.tasks must be a non-empty list of distinct task names, not []"),
        ("benchmark.tasks=[open_drawer,open_drawer]",
         "benchmark.tasks must be a non-empty list of distinct task names, not ['open_drawer', 'open_drawer']"),
    ],
)
def test_a_value_out_of_range_stops_the_run_and_the_collection(override, sentence):
    cfg = _compose([override])  # the type is right, so Hydra composes it
    with pytest.raises(ConfigError) as run:
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))
    assert str(run.value) == sentence
    with pytest.raises(ConfigError, match=f"^{re.escape(sentence)}$"):
        check_overrides([override], XicmConfig)  # the same sentence on the command line, before Hydra


@pytest.mark.parametrize(
    "override, sentence",
    [
        ("episodes=abc", "episodes must be an integer >= 1, not 'abc'"),
        ("max_steps=2.5", "max_steps must be an integer >= 1, not 2.5"),
        ("seeds=[0,x]", f"seeds must be {SEEDS}, not [0, 'x']"),
        ("progress=maybe", "progress must be true or false, not 'maybe'"),
        ("shards.workers=many", "shards.workers must be an integer >= 1, not 'many'"),
        ("shards.address=[1]", "shards.address must be a string or null, not [1]"),
        ("benchmark.tasks=open_drawer", "benchmark.tasks must be a non-empty list of distinct task names, not 'open_drawer'"),
    ],
)
def test_a_value_of_the_wrong_type_is_one_sentence_before_hydra_composes(override, sentence):
    with pytest.raises(ConfigError) as err:
        check_overrides([override], XicmConfig)
    assert str(err.value) == sentence
    with pytest.raises(Exception, match="Error merging override"):  # Hydra's typed compose refuses it too
        _compose([override])


def test_what_the_command_line_check_leaves_to_hydra():
    """Group choices, flags, appends, interpolations and hydra.* are not values of the schema; a
    plugin's option (policy.k) is checked after composing; a malformed override is Hydra's to report."""
    args = ["-m", "--cfg", "job", "benchmark=level1", "llm=gemma3_270m", "+experiment=smoke", "~video",
            "hydra.run.dir=x", "episodes=${max_steps}", "episodes=range(1,4)", "policy.k=0", "seeds=[0,",
            "experiment=smoke"]  # Hydra says: use +experiment=smoke
    assert check_overrides(args, XicmConfig, groups={"experiment"}) is None


@pytest.mark.parametrize(
    "override, sentence",
    [
        ("collect.worker=2", "unknown key collect.worker (did you mean collect.workers?); collect has: "
                             "demos_per_task, seed, max_attempts_factor, workers"),
        ("video.colour=red", "unknown key video.colour; video has: enabled, camera, fps, every"),
        ("retreiver=random", f"unknown key retreiver (did you mean retriever?); the config has: {', '.join(TOP_KEYS)}"),
    ],
)
def test_a_key_the_config_does_not_have_is_one_sentence(override, sentence):
    with pytest.raises(ConfigError) as err:
        check_overrides([override], XicmConfig, groups={"experiment"})
    assert str(err.value) == sentence


# ------------------------------------------------------------------ plugins' options
@pytest.mark.parametrize(
    "overrides, sentence",
    [
        (["policy.k=0"], "policy.k must be an integer >= 1, not 0"),
        (["policy.max_llm_calls=0"], "policy.max_llm_calls must be an integer >= 1 or null, not 0"),
        (["simulator.image_size=[0,64]"], f"simulator.image_size must be {IMAGE_SIZE}, not [0, 64]"),
        (["simulator.image_size=4097"], f"simulator.image_size must be {IMAGE_SIZE}, not 4097"),
        (["simulator.image_size=[64,64,3]"], f"simulator.image_size must be {IMAGE_SIZE}, not [64, 64, 3]"),
        (["simulator.cameras=[nope]"],
         "simulator.cameras must be a non-empty list of distinct names from front, left_shoulder, right_shoulder, "
         "overhead, wrist, not ['nope']"),
        (["simulator.physics_hz=0"], "simulator.physics_hz must be a number > 0, not 0"),
        (["simulator.image_size={front: 5000}"], f"simulator.image_size must be {IMAGE_SIZE}, not {{\"front\": 5000}}"),
        (["simulator.control_hz=15"], "simulator.frame_hz (20) must be a whole multiple of simulator.control_hz (15), e.g. frame_hz 20 with control_hz 10, 20 or 5"),
    ],
)
def test_the_simulator_and_the_policy_options_are_checked_before_anything_is_built(overrides, sentence):
    cfg = _compose(overrides)
    with pytest.raises(ConfigError) as err:
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))
    assert str(err.value) == sentence


@pytest.mark.parametrize(
    "overrides, sentence",
    [
        (["llm=qwen2_5_7b", "llm.max_new_tokens=0"], "llm.max_new_tokens must be an integer >= 1, not 0"),
        (["llm=qwen2_5_7b", "llm.temperature=-1"], "llm.temperature must be a number > 0, not -1"),
        (["llm=qwen2_5_7b", "llm.max_new_tokens=many"], "llm.max_new_tokens must be an integer >= 1, not 'many'"),
        (["llm=qwen2_5_7b", "+llm.prompt_overflow=drop"], "llm.prompt_overflow must be one of error, truncate_left, not 'drop'"),
        (["llm=openai", "llm.retries=-1"], "llm.retries must be an integer >= 0, not -1"),
        (["llm=openai", "llm.mode=stream"], "llm.mode must be one of chat, completion, not 'stream'"),
        (["+llm.demo_rank=-1"], "llm.demo_rank must be an integer >= 0, not -1"),
        (["detector=noisy_oracle", "detector.noise_cm=-1"], "detector.noise_cm must be a number >= 0, not -1"),
        (["detector=noisy_oracle", "detector.drop_prob=1.5"], "detector.drop_prob must be a number from 0 to 1, not 1.5"),
        (["detector.cameras=[]"], "detector.cameras must be a non-empty list of distinct camera names or null, not []"),
        (["detector=grounding_dino", "detector.box_threshold=2"], "detector.box_threshold must be a number from 0 to 1, not 2"),
        (["retriever.exclude_same_task=maybe"], "retriever.exclude_same_task must be true or false, not 'maybe'"),
        (["retriever.cache_dir=[a]"], "retriever.cache_dir must be a string or null, not ['a']"),
        (["retriever=dynamics", "encoder.steps=0"], "encoder.steps must be an integer >= 1, not 0"),
        (["retriever=dynamics", "encoder.mode=pixels"], "encoder.mode must be one of predicted_frame, unet_features, not 'pixels'"),
        (["retriever=dynamics", "~encoder.checkpoint"],
         "encoder.checkpoint must be set to a string; encoder 'dynamics' has no default for it"),
        (["+prompt.k=18"], "unknown option prompt.k of prompt 'xicm'; available: system_prompt"),
        (["+llm.k=3", "+llm.top_k=3"], "unknown options llm.k, llm.top_k of llm 'nearest_demo'; available: demo_rank, grammar, reply, stop_at_action_list"),
    ],
)
def test_the_policy_parts_options_are_checked_before_anything_is_built(tmp_path, overrides, sentence):
    cfg = _compose([f"paths.data={tmp_path}", *overrides])  # no pool there: the options are checked before it
    with pytest.raises(ConfigError) as err:
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))
    assert str(err.value) == sentence


def test_the_collection_checks_its_simulator_and_detector(tmp_path):
    from xicm.core.assembly.collect_job import run_collect

    with pytest.raises(ConfigError, match="^detector.noise_cm must be a number >= 0, not -1$"):
        run_collect(_compose([f"paths.data={tmp_path}", "detector=noisy_oracle", "detector.noise_cm=-1"]))
    with pytest.raises(ConfigError, match="^simulator.image_size must be"):
        run_collect(_compose([f"paths.data={tmp_path}", "simulator.image_size=0"]))
    assert not (tmp_path / "pools").exists()


def test_a_plugin_registered_without_a_schema_keeps_its_factory_check():
    from xicm.core.contracts.hookspecs import hookimpl
    from xicm.core.assembly.plugins import Registry, make_plugin_manager

    class Parrot:
        deterministic = True

        def __init__(self, reply="ok"):
            self.reply = reply

        def complete(self, prompt):
            return self.reply

    class NoSchema:
        @hookimpl
        def register_llms(self, register):
            register("parrot", Parrot)

    pm = make_plugin_manager()
    pm.register(NoSchema(), name="no_schema")
    registry = Registry(pm)
    assert registry.check_options("llm", {"name": "parrot", "colour": "red"}).factory is Parrot  # nothing to check
    with pytest.raises(ConfigError, match=r"^llm 'parrot' got an option it does not take: .*'colour'"):
        registry.create("llm", {"name": "parrot", "colour": "red"})


# ------------------------------------------------------------------ what exists passes
def _options_files():
    for group in PLUGIN_GROUPS:
        for path in sorted((CONF / group).glob("*.yaml")):
            yield group, path.stem


@pytest.mark.parametrize("group, option", list(_options_files()))
def test_every_shipped_option_file_passes_its_plugins_schema(group, option):
    cfg = _compose([f"{group}={option}"])
    check_config(cfg, XicmConfig)
    options = build.group_options(cfg, group)
    if options["name"] is not None:  # encoder=none
        assert get_registry().check_options(group, options).name == options["name"]


@pytest.mark.parametrize("name", sorted(p.stem for p in (CONF / "experiment").glob("*.yaml")))
def test_every_experiment_passes_every_schema(name):
    cfg = _compose([f"+experiment={name}"])
    check_config(cfg, XicmConfig)
    for group in PLUGIN_GROUPS:
        options = build.group_options(cfg, group)
        if options["name"] is not None:
            assert get_registry().check_options(group, options).name == options["name"]


def test_the_paper_presets_select_demos_as_xicm_does():
    """Image-only features ranked by the raw dot product (docs/reference/protocol-and-fidelity.md, the selection row)."""
    for name in ("paper_table2", "ablation_k", "ablation_llm"):
        cfg = _compose([f"+experiment={name}"])
        assert (cfg.retriever.name, cfg.retriever.score) == ("dynamics", "dot"), name
        assert (cfg.encoder.visual, cfg.encoder.text_weight, cfg.encoder.normalise) == ("final", 0.0, False), name
    ours = _compose(["retriever=dynamics"])
    assert (ours.retriever.score, ours.encoder.visual, ours.encoder.normalise) == ("cosine", "change", True)


def test_the_paper_pool_is_collected_with_the_paper_presets_simulator():
    pool, paper = _compose(["+experiment=paper_pool"]), _compose(["+experiment=paper_table2"])
    assert (pool.benchmark.name, pool.collect.demos_per_task, pool.pool_path) == ("seen", 200, paper.pool_path)
    assert pool.pool_path.endswith("pools/paper.h5") and pool.simulator == paper.simulator
    assert (paper.simulator.robot, paper.simulator.gripper_after_success, paper.policy.parse_fallback) == ("rlbench", True, True)
    assert _compose([]).simulator.robot == "ours"


def _schemas():
    registry = get_registry()
    for kind in PLUGIN_GROUPS:
        for name in registry.names(kind):
            reg = registry.get(kind, name)
            if reg.plugin in DEFAULT_PLUGINS:
                yield kind, name, reg


@pytest.mark.parametrize("kind, name, reg", list(_schemas()), ids=lambda v: v if isinstance(v, str) else "")
def test_every_built_in_plugin_takes_its_options_as_one_object(kind, name, reg):
    """The schema is the one place a plugin's options and defaults are written: its factory takes
    an instance of it (Registry.create) and no option of its own, so nothing can drift."""
    assert reg.extra.get("options") is not None, f"{kind} '{name}' registers no options schema"
    factory = reg.factory.__init__ if inspect.isclass(reg.factory) else reg.factory
    params = [p for p in inspect.signature(factory).parameters if p != "self"]
    assert params[0] == "options" and set(params[1:]) <= {"encoder", "context", "tasks"}, params


def test_sapien_yaml_declares_every_simulator_option_with_its_default():
    """One declaration: SapienOptions; the group's YAML lists each option with that default, so every
    documented key is a plain override (simulator.control_hz=20, no `+`)."""
    from omegaconf import OmegaConf

    from xicm.plugins.simulators.sapien.options import SapienOptions

    declared = OmegaConf.to_container(OmegaConf.load(CONF / "simulator" / "sapien.yaml"))
    assert declared.pop("name") == "sapien"
    assert declared == OmegaConf.to_container(OmegaConf.structured(SapienOptions))


def test_llamacpp_yaml_declares_every_llamacpp_option_with_its_default():
    """As sapien.yaml: LlamaCppOptions is the declaration, the group's base YAML lists it whole."""
    from omegaconf import OmegaConf

    from xicm.plugins.llms.llamacpp_options import LlamaCppOptions

    raw = OmegaConf.load(CONF / "llm" / "llamacpp.yaml")
    assert OmegaConf.to_container(raw)["parallel"] == "${envs}"  # one server slot per environment of the run
    # resolved as a run with one environment resolves it
    declared = OmegaConf.to_container(OmegaConf.create({"envs": 1, "llm": raw}), resolve=True)["llm"]
    assert declared.pop("name") == "llamacpp"
    assert declared == OmegaConf.to_container(OmegaConf.structured(LlamaCppOptions))


#: keys the transformers_local confs list only to show them, at the schema's default
SHOWN_AT_DEFAULT = ("torch_threads", "on_repeated_action")


def _transformers_local_confs():
    from omegaconf import OmegaConf

    return [p for p in sorted((CONF / "llm").glob("*.yaml")) if OmegaConf.load(p).get("name") == "transformers_local"]


@pytest.mark.parametrize("path", _transformers_local_confs(), ids=lambda p: p.stem)
def test_transformers_local_confs_take_only_its_options_and_show_defaults_unchanged(path):
    """Each transformers_local conf sets options of TransformersLocalOptions only, and the keys it
    lists to show them (SHOWN_AT_DEFAULT) hold the schema's defaults, so the two cannot drift."""
    from omegaconf import OmegaConf

    from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

    conf = OmegaConf.to_container(OmegaConf.load(path))
    schema = OmegaConf.to_container(OmegaConf.structured(TransformersLocalOptions))
    assert set(conf) - {"name"} <= set(schema), sorted(set(conf) - {"name"} - set(schema))
    assert {k: conf[k] for k in SHOWN_AT_DEFAULT} == {k: schema[k] for k in SHOWN_AT_DEFAULT}


def test_a_replaced_simulator_option_names_the_key_that_replaced_it():
    cfg = _compose(["+simulator.sample_variations=false"])
    with pytest.raises(ConfigError, match=r"^simulator.sample_variations is no longer an option of simulator 'sapien'; "
                                          r"set benchmark.variations \(zero \| sampled\) instead$"):
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))


# ------------------------------------------------------------------ xicm-train-dynamics (the dynamics plugin's config)
def _compose_training(overrides=()):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("train_dynamics", overrides=list(overrides))


@pytest.mark.parametrize(
    "override, sentence",
    [
        ("train.steps=0", "train.steps must be an integer >= 1, not 0"),
        ("train.lr=0", "train.lr must be a number > 0, not 0.0"),
        ("train.heldout_every=-1", "train.heldout_every must be an integer >= 0, not -1"),
        ("evaluation.sample_steps=[1,0]", "evaluation.sample_steps must be a DDIM step count >= 1 or a non-empty list of them, not [1, 0]"),
        ("dynamics_model.prediction=x0", "dynamics_model.prediction must be one of epsilon, v_prediction, sample, not 'x0'"),
        ("tracking.mode=bogus", "tracking.mode must be one of offline, online, disabled, not 'bogus'"),
    ],
)
def test_a_bad_training_value_stops_before_the_training(override, sentence):
    from xicm.plugins.dynamics.config_schema import TrainDynamicsConfig

    with pytest.raises(ConfigError) as err:
        check_config(_compose_training([override]), TrainDynamicsConfig)
    assert str(err.value) == sentence


def test_xicm_train_dynamics_stops_at_start_with_one_sentence(tmp_path, monkeypatch, capsys):
    from xicm.plugins.dynamics.cli import main

    out = run_main(main, "xicm-train-dynamics", f"paths.data={tmp_path}", "train.steps=abc", cwd=tmp_path, monkeypatch=monkeypatch, capsys=capsys)
    assert _one_sentence(out) == "xicm: error: train.steps must be an integer >= 1, not 'abc'"

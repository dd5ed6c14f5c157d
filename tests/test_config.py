import json
import os
from pathlib import Path

import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

from cli_in_process import run_main
from xicm.core.assembly import build, checks
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import UnknownPluginError, get_registry

CONF = Path(__file__).resolve().parents[1] / "src/xicm/conf"
GROUPS = ["simulator", "detector", "encoder", "retriever", "prompt", "llm", "benchmark", "policy"]


def _compose(overrides=()):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("config", overrides=list(overrides))


@pytest.mark.parametrize("group", GROUPS)
def test_every_option_of_every_group_composes_and_names_a_registered_plugin(group):
    registry = get_registry()
    for option in sorted(p.stem for p in (CONF / group).glob("*.yaml")):
        cfg = _compose([f"{group}={option}"])
        if group == "benchmark":
            known = set(registry.names("task"))
            assert set(cfg.benchmark.pool_tasks) <= known and set(cfg.benchmark.tasks) <= known
            continue
        name = cfg[group].name
        if name is not None:
            registry.get(group, name)


def test_retriever_choice_sets_its_encoder():
    assert _compose(["retriever=random"]).encoder.name is None
    assert _compose(["retriever=language"]).encoder.name == "minilm"


def test_unknown_plugin_name_stops_with_the_list(tmp_path):
    cfg = _compose(["llm.name=nope"])
    with pytest.raises(UnknownPluginError, match="unknown llm 'nope'; available: .*nearest_demo"):
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))


def test_unknown_task_stops_with_the_list():
    cfg = _compose(["benchmark.tasks=[open_drawer,make_coffee]"])
    with pytest.raises(ConfigError, match="unknown task 'make_coffee' for simulator 'sapien'; available: .*open_drawer"):
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))


@pytest.mark.parametrize("value, workers", [("auto", None), (1, 1), ("3", 3)])
def test_collect_workers(value, workers):
    from xicm.core.assembly.collect_job import resolve_workers

    assert resolve_workers(value) == (workers or os.cpu_count())


def test_missing_pool_says_what_to_run_before_anything_is_built(tmp_path):
    cfg = _compose([f"paths.data={tmp_path}"])
    with pytest.raises(ConfigError, match=f"no demonstration pool at {tmp_path}/pools/smoke.h5; run `xicm-collect"):
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))


@pytest.fixture
def cli(monkeypatch, capsys):
    """xicm-eval with these arguments, in this process (cli_in_process.py)."""
    from xicm.core.assembly.cli import eval_main

    return lambda *args, cwd: run_main(eval_main, "xicm-eval", *args, cwd=cwd, monkeypatch=monkeypatch, capsys=capsys)


def test_cli_bad_group_option_names_the_options(cli, tmp_path):
    out = cli("llm=gpt17", cwd=tmp_path)
    assert out.returncode != 0
    assert "Could not find 'llm/gpt17'" in out.stderr and "nearest_demo" in out.stderr


def test_cli_unknown_plugin_is_one_clear_sentence(cli, tmp_path):
    out = cli("detector.name=xray", cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr.strip().splitlines()[-1] == (
        "xicm: error: unknown detector 'xray'; available: " + ", ".join(get_registry().names("detector"))
    )


def test_cli_missing_pool_is_one_clear_sentence(cli, tmp_path):
    out = cli(f"paths.data={tmp_path}/nothing", cwd=tmp_path)
    assert out.returncode == 2
    assert "no demonstration pool at" in out.stderr and "xicm-collect" in out.stderr


def test_an_in_process_run_leaves_the_root_logger_as_it_found_it(cli, tmp_path):
    import logging

    before = logging.getLogger().handlers[:]
    out = cli(f"paths.data={tmp_path}/nothing", cwd=tmp_path)  # far enough for Hydra to set up the job's logging
    assert out.returncode == 2 and (tmp_path / "outputs").is_dir()
    assert logging.getLogger().handlers == before


def test_help_is_fast_and_lists_groups(cli, tmp_path):
    out = cli("--help", cwd=tmp_path)
    assert out.returncode == 0
    assert "llm: " in out.stdout and "retriever: " in out.stdout


def test_config_resolves_without_hydra_runtime_except_run_name():
    cfg = _compose()
    container = OmegaConf.to_container(cfg, resolve=False)
    container.pop("run_name")
    assert OmegaConf.create(container).pool_path.endswith("pools/smoke.h5")


def test_cli_malformed_override_is_reported(cli, tmp_path):
    out = cli("seeds=[0,", cwd=tmp_path)
    assert out.returncode != 0
    assert "no viable alternative at input '[0,'" in out.stderr and "Traceback" not in out.stderr


def test_unknown_policy_stops_with_the_list():
    cfg = _compose(["policy.name=greedy"])
    with pytest.raises(UnknownPluginError, match="unknown policy 'greedy'; available: oracle, remote, xicm"):
        checks.check_run(cfg, get_registry(), list(cfg.benchmark.tasks))


def test_long_sweep_folder_names_are_cut_and_hashed():
    from xicm.core.results.run_dir import FOLDER_NAME_LIMIT, short_name

    long = "benchmark.tasks=[" + ",".join(f"task_number_{i}" for i in range(40)) + "],detector.noise_cm="
    a, b = short_name(long + "0", FOLDER_NAME_LIMIT), short_name(long + "8", FOLDER_NAME_LIMIT)
    assert len(a) == 131 and a != b and a.startswith(long[:120])
    assert short_name("policy.k=6", FOLDER_NAME_LIMIT) == "policy.k=6"


SINGLE_RUN_EXPERIMENTS = {"paper_protocol", "paper_pool"}  # the protocol the paper presets share; the paper's pool


@pytest.mark.parametrize("name", sorted(p.stem for p in (CONF / "experiment").glob("*.yaml")))
def test_every_experiment_composes_and_sweeps_what_exists(name):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config", overrides=[f"+experiment={name}"], return_hydra_config=True)
    params = dict(cfg.hydra.sweeper.params or {})
    assert params or name in SINGLE_RUN_EXPERIMENTS, f"experiment {name} sweeps nothing"
    for key, values in params.items():
        if key in GROUPS:  # a config group: every swept option must be a file of the group
            options = {p.stem for p in (CONF / key).glob("*.yaml")}
            assert set(str(values).split(",")) <= options, (key, values)
        else:  # a value: the key must exist in the composed config
            assert OmegaConf.select(cfg, key) is not None, key
    assert set(cfg.benchmark.tasks) <= set(get_registry().names("task"))


@pytest.mark.parametrize("policy", ["oracle", "remote"])
def test_the_paper_presets_compose_with_any_policy(policy):
    """X-ICM's own policy keys live in src/xicm/conf/policy/xicm_paper.yaml (the presets' policy), so
    choosing another policy drops them instead of failing their unknown-key check."""
    cfg = _compose(["+experiment=paper_table2", f"policy={policy}"])
    get_registry().check_options("policy", build.group_options(cfg, "policy"))
    assert (cfg.simulator.robot, cfg.seeds, cfg.episodes) == ("rlbench", [0, 1, 2], 25)  # the preset still applies
    assert cfg.policy.name == policy and "rerank" not in cfg.policy
    paper = _compose(["+experiment=paper_protocol"]).policy
    assert (paper.name, paper.k, paper.rerank, paper.partial_replies, paper.parse_fallback) == ("xicm", 18, True, True, True)


def test_the_oracle_row_of_the_paper_settings_is_one_command(cli, tmp_path):
    out = cli("+experiment=paper_protocol", "policy=oracle", "benchmark.tasks=[close_microwave]", "seeds=[0]",
              "episodes=1", "simulator.image_size=32", f"paths.data={tmp_path}/nothing", "hydra.run.dir=run", "progress=false",
              cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    (row,) = [json.loads(line) for line in (tmp_path / "run" / "episodes.jsonl").read_text().splitlines()]
    assert (row["task"], row["success"]) == ("close_microwave", True)
    run = json.loads((tmp_path / "run" / "run.json").read_text())
    assert run["policy"] == "oracle" and run["config"]["simulator"]["success_check"] == "per_frame"

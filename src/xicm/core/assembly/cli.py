"""Console scripts. Hydra apps share src/xicm/conf/; heavy imports happen only inside the jobs."""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

import xicm.conf  # noqa: F401  (registers the configs' OmegaConf resolvers and schema)
from xicm.core.contracts.errors import XicmError
from xicm.core.contracts.errors import exit_with_error as _fail
from xicm.core.assembly.plugins import UnknownPluginError

CONFIG_PATH = "../../conf"  # from xicm/core/assembly/ to xicm/conf/, in the checkout (src/) and in the wheel


def _check_command_line() -> None:
    """A command-line value of the wrong type or range, or an unknown key: one sentence, before Hydra composes."""
    from xicm.core.assembly.config_schema import XicmConfig
    from xicm.core.assembly.literal_keys import refuse_literal_keys_on_command_line
    from xicm.core.contracts.schema import check_overrides

    try:
        refuse_literal_keys_on_command_line(sys.argv[1:])  # before Hydra writes .hydra/overrides.yaml
        check_overrides(sys.argv[1:], XicmConfig, xicm.conf.groups())
    except XicmError as exc:
        _fail(exc)


def eval_main() -> None:
    """xicm-eval: evaluate a policy on the benchmark's tasks and print the success table."""
    _check_command_line()
    _eval_job()


def collect_main() -> None:
    """xicm-collect: record scripted demonstrations of benchmark.pool_tasks into pool_path (resumable)."""
    _check_command_line()
    _collect_job()


def export_main() -> None:
    """xicm-export: record export.tasks' scripted demos at the control rate into a LeRobot dataset (resumable)."""
    _check_command_line()
    _export_job()


def serve_policy_main() -> None:
    """xicm-serve-policy: serve the configured policy over openpi's websocket protocol until Ctrl-C."""
    _check_command_line()
    _serve_job()


@hydra.main(version_base="1.3", config_path=CONFIG_PATH, config_name="config")
def _serve_job(cfg: DictConfig) -> None:
    from xicm.serving.serve_job import serve_policy

    try:
        serve_policy(cfg)
    except (XicmError, UnknownPluginError) as exc:
        _fail(exc)


@hydra.main(version_base="1.3", config_path=CONFIG_PATH, config_name="config")
def _eval_job(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    from xicm.core.assembly.eval_job import run_eval
    from xicm.report.summary import markdown_table
    from xicm.core.results.run_dir import EPISODES, REPORT_FILES

    out_dir = Path(HydraConfig.get().runtime.output_dir)
    try:
        summary = run_eval(cfg, out_dir)
    except (XicmError, UnknownPluginError) as exc:
        _fail(exc)
    print()
    print(markdown_table(summary))
    written = [*REPORT_FILES, *(["report.html"] if (out_dir / "report.html").is_file() and cfg.report.html else [])]
    print(f"\nresults: {out_dir}/ ({', '.join((EPISODES, *written))})")


@hydra.main(version_base="1.3", config_path=CONFIG_PATH, config_name="config")
def _collect_job(cfg: DictConfig) -> None:
    from xicm.core.assembly.collect_job import run_collect

    try:
        run_collect(cfg)
    except (XicmError, UnknownPluginError) as exc:
        _fail(exc)


@hydra.main(version_base="1.3", config_path=CONFIG_PATH, config_name="config")
def _export_job(cfg: DictConfig) -> None:
    from xicm.export.job import run_export

    try:
        run_export(cfg)
    except (XicmError, UnknownPluginError) as exc:
        _fail(exc)


def plugins_main() -> None:
    """Print every loaded plugin with its version and hooks, and what each family offers."""
    from xicm.core.assembly.plugins import KINDS, describe_plugins, get_registry

    registry = get_registry()
    for row in describe_plugins(registry.pm):
        print(f"{row['name']} {row['version']}: {', '.join(row['hooks'])}")
    for name, why in sorted(registry.failed.items()):
        print(f"{name}: NOT LOADED ({why})")
    print()
    for kind in KINDS:
        print(f"{kind}: {', '.join(registry.names(kind)) or '-'}")

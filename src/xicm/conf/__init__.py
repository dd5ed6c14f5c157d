"""The Hydra config tree: config.yaml and one folder per config group.

A package so that `initialize_config_module("xicm.conf")` and `pkg://xicm.conf` find it. Importing it registers the OmegaConf resolvers the configs use and
stores the schemas of config.yaml (xicm.core.assembly.config_schema) and of train_dynamics.yaml (the
dynamics plugin's, xicm.plugins.dynamics.config_schema) in Hydra's ConfigStore."""

from importlib.resources import files

from omegaconf import OmegaConf

from xicm.core.assembly import config_schema
from xicm.core.results.run_dir import FOLDER_NAME_LIMIT, overrides_outside_identity, short_name
from xicm.plugins.dynamics import config_schema as dynamics_schema


def first_set(*values):
    """The first value that is set (not None, not empty): `${xicm_first:${a},${b}}` is a, else b."""
    return next((v for v in values if v not in (None, "")), None)


def excluded_from_folder_names(*, _root_) -> list[str]:
    """`${xicm_outside_identity:}`: the keys of this job's overrides that are outside a run's
    identity (src/xicm/core/results/run_dir.py), for hydra.job.config.override_dirname.exclude_keys."""
    return overrides_outside_identity(_root_.hydra.overrides.task)


if not OmegaConf.has_resolver("xicm_dirname"):  # long names are cut and hashed, so they stay distinct
    OmegaConf.register_new_resolver("xicm_dirname", lambda text: short_name(text, FOLDER_NAME_LIMIT))
if not OmegaConf.has_resolver("xicm_first"):
    OmegaConf.register_new_resolver("xicm_first", first_set)
if not OmegaConf.has_resolver("xicm_outside_identity"):
    OmegaConf.register_new_resolver("xicm_outside_identity", excluded_from_folder_names)


def groups() -> set[str]:
    """The config groups of this tree (its folders): a command-line key naming one is a group choice."""
    return {p.name for p in files(__name__).iterdir() if p.is_dir() and not p.name.startswith("_")}


config_schema.store_schema()
dynamics_schema.store_schema()

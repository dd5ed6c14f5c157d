"""The Hydra config tree of xicm (a package so that `initialize_config_module("xicm.conf")` and
`pkg://xicm.conf` find it). Importing it registers the OmegaConf resolvers the configs use and
stores the schemas of config.yaml (xicm.core.config_schema) and of train_dynamics.yaml (the
dynamics plugin's, xicm.plugins.dynamics.config_schema) in Hydra's ConfigStore."""

import hashlib

from importlib.resources import files

from omegaconf import OmegaConf

from xicm.core import config_schema
from xicm.plugins.dynamics import config_schema as dynamics_schema


def short_dirname(text: str, limit: int = 120) -> str:
    """A folder name of at most `limit` + 11 characters: long ones (e.g. a sweep over a long
    task list) keep their start and get a hash of the whole, so they stay distinct."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}-{hashlib.sha1(text.encode()).hexdigest()[:10]}"


def first_set(*values):
    """The first value that is set (not None, not empty): `${xicm_first:${a},${b}}` is a, else b."""
    return next((v for v in values if v not in (None, "")), None)


if not OmegaConf.has_resolver("xicm_dirname"):
    OmegaConf.register_new_resolver("xicm_dirname", short_dirname)
if not OmegaConf.has_resolver("xicm_first"):
    OmegaConf.register_new_resolver("xicm_first", first_set)


def groups() -> set[str]:
    """The config groups of this tree (its folders): a command-line key naming one is a group choice."""
    return {p.name for p in files(__name__).iterdir() if p.is_dir() and not p.name.startswith("_")}


config_schema.store_schema()
dynamics_schema.store_schema()

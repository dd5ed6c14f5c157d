"""The Hydra config tree of xicm (a package so that `initialize_config_module("xicm.conf")` and
`pkg://xicm.conf` find it). Importing it registers the OmegaConf resolvers the configs use."""

from omegaconf import OmegaConf

from xicm.core.run_dir import FOLDER_NAME_LIMIT, overrides_outside_identity, short_name


def first_set(*values):
    """The first value that is set (not None, not empty): `${xicm_first:${a},${b}}` is a, else b."""
    return next((v for v in values if v not in (None, "")), None)


def excluded_from_folder_names(*, _root_) -> list[str]:
    """`${xicm_outside_identity:}`: the keys of this job's overrides that are outside a run's
    identity (core/run_dir.py), for hydra.job.config.override_dirname.exclude_keys."""
    return overrides_outside_identity(_root_.hydra.overrides.task)


if not OmegaConf.has_resolver("xicm_dirname"):  # long names are cut and hashed, so they stay distinct
    OmegaConf.register_new_resolver("xicm_dirname", lambda text: short_name(text, FOLDER_NAME_LIMIT))
if not OmegaConf.has_resolver("xicm_first"):
    OmegaConf.register_new_resolver("xicm_first", first_set)
if not OmegaConf.has_resolver("xicm_outside_identity"):
    OmegaConf.register_new_resolver("xicm_outside_identity", excluded_from_folder_names)

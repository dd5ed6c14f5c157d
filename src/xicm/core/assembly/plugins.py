"""Loads plugins (built-in and from the `xicm` entry-point group) and looks them up by name."""

from __future__ import annotations

import importlib
import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import TYPE_CHECKING, Any, Callable

import pluggy

from xicm.core.contracts import hookspecs

if TYPE_CHECKING:
    from xicm.core.contracts.types import TaskInfo

log = logging.getLogger(__name__)

#: The built-in plugins, by name: the one place they are listed (third-party plugins come from
#: the `xicm` entry-point group). Loaded like any plugin, so XICM_DISABLE_PLUGINS applies to them.
DEFAULT_PLUGINS = {
    "sapien": "xicm.plugins.simulators.sapien",
    "oracle_detector": "xicm.plugins.detectors.oracle",
    "noisy_oracle_detector": "xicm.plugins.detectors.noisy_oracle",
    "grounding_dino_detector": "xicm.plugins.detectors.grounding_dino",
    "random_retriever": "xicm.plugins.retrievers.random",
    "similarity_retriever": "xicm.plugins.retrievers.similarity",
    "minilm_encoder": "xicm.plugins.encoders.minilm",
    "dynamics_encoder": "xicm.plugins.encoders.dynamics",
    "dynamics_retriever": "xicm.plugins.retrievers.dynamics",
    "xicm_prompt": "xicm.plugins.prompts.xicm_prompt",
    "xicm_paper_prompt": "xicm.plugins.prompts.xicm_paper",
    "transformers_local": "xicm.plugins.llms.transformers_local",
    "openai_compatible": "xicm.plugins.llms.openai_compatible",
    "llamacpp": "xicm.plugins.llms.llamacpp",
    "nearest_demo": "xicm.plugins.llms.nearest_demo",
    "xicm_policy": "xicm.plugins.policies.xicm",
    "oracle_policy": "xicm.plugins.policies.oracle",
    "remote_policy": "xicm.plugins.policies.remote",
}

#: plugin family -> hook that fills it
KINDS = {
    "simulator": "register_simulators",
    "task": "register_tasks",
    "detector": "register_detectors",
    "encoder": "register_encoders",
    "retriever": "register_retrievers",
    "prompt": "register_prompt_builders",
    "llm": "register_llms",
    "policy": "register_policies",
}


class UnknownPluginError(LookupError):
    """A config named a plugin that no loaded plugin registers."""


class PluginConflictError(RuntimeError):
    """Two plugins registered the same name in the same family."""


@dataclass(frozen=True)
class Registration:
    name: str
    factory: Callable[..., Any]
    plugin: str  # name of the plugin module that registered it
    extra: dict[str, Any]


class Registry:
    """All registrations of one plugin manager, by family and name."""

    def __init__(self, pm: pluggy.PluginManager):
        self.pm = pm
        self.failed: dict[str, str] = dict(getattr(pm, "xicm_failed", {}))
        self._entries: dict[str, dict[str, Registration]] = {kind: {} for kind in KINDS}
        for kind, hook_name in KINDS.items():
            hook = getattr(pm.hook, hook_name)
            for impl in hook.get_hookimpls():
                plugin_name = pm.get_name(impl.plugin) or repr(impl.plugin)
                try:
                    impl.function(register=self._register_fn(kind, plugin_name))
                except PluginConflictError:
                    raise
                except Exception as exc:  # noqa: BLE001 - report it by name, keep the other plugins
                    self.failed[plugin_name] = f"{hook_name} raised {type(exc).__name__}: {exc}"
                    log.warning("plugin %s: %s", plugin_name, self.failed[plugin_name])

    def _register_fn(self, kind: str, plugin_name: str):
        def register(name: str, factory: Callable[..., Any], **extra: Any) -> None:
            if kind == "task" and not isinstance(extra.get("simulator"), str):  # fails the plugin, by name
                raise TypeError(f"task '{name}' is registered without simulator=NAME (the simulator that loads it)")
            entries = self._entries[kind]
            if name in entries and entries[name].plugin != plugin_name:
                raise PluginConflictError(
                    f"{kind} '{name}' is registered by both {entries[name].plugin} and {plugin_name}"
                )
            entries[name] = Registration(name, factory, plugin_name, extra)

        return register

    def names(self, kind: str) -> list[str]:
        return sorted(self._entries[kind])

    def get(self, kind: str, name: str) -> Registration:
        if kind not in self._entries:
            raise UnknownPluginError(f"unknown plugin family '{kind}'; available: {', '.join(KINDS)}")
        try:
            return self._entries[kind][name]
        except KeyError:
            available = ", ".join(self.names(kind)) or "none"
            broken = "".join(f"; plugin {p} failed to load ({why})" for p, why in sorted(self.failed.items()))
            raise UnknownPluginError(f"unknown {kind} '{name}'; available: {available}{broken}") from None

    def tasks(self, simulator: str) -> dict[str, Any]:
        """The tasks registered for `simulator`: name -> task class (or a stand-in called like one), by name."""
        entries = self._entries["task"]
        return {n: entries[n].factory for n in sorted(entries) if entries[n].extra["simulator"] == simulator}

    def task_info(self, name: str) -> TaskInfo:
        """A registered task's name, split, instruction and object names, without building a simulator."""
        from xicm.core.contracts.types import TaskInfo

        return TaskInfo.of(name, self.get("task", name).factory)

    def create_simulator(self, options: dict[str, Any]) -> Any:
        """The simulator options['name'] names, built as factory(**options, tasks=<its registered tasks>)."""
        return self.create("simulator", options, tasks=self.tasks(simulator=options.get("name")))

    def check_options(self, kind: str, options: dict[str, Any]) -> Registration:
        """The registration options['name'] picks, its other options checked against the schema it
        registered (`options=`, a dataclass: xicm.core.contracts.schema); without one, create() finds out.
        A key the plugin registered as `replaced={old: new}` is refused with a sentence naming the new key."""
        if "name" not in options:
            raise UnknownPluginError(f"the {kind} config has no 'name'; available: {', '.join(self.names(kind))}")
        reg = self.get(kind, options["name"])
        for old, new in reg.extra.get("replaced", {}).items():
            if old in options:
                from xicm.core.contracts.errors import ConfigError

                raise ConfigError(f"{kind}.{old} is no longer an option of {kind} '{reg.name}'; set {new} instead")
        if reg.extra.get("options") is not None:
            from xicm.core.contracts.schema import check_options

            values = {k: v for k, v in options.items() if k != "name"}
            check_options(values, reg.extra["options"], prefix=kind, owner=f"{kind} '{reg.name}'")
        return reg

    def how_keys(self, cfg: Mapping[str, Any]) -> list[str]:
        """The dotted config keys of the configured plugins' options that say how a run is done,
        not what it measures (fields their schema marks with xicm.core.contracts.schema.how):
        kept outside the run's identity, so changing one resumes a run."""
        from xicm.core.contracts.schema import how_fields

        keys = []
        for kind in KINDS:
            group = cfg.get(kind)
            name = group.get("name") if isinstance(group, Mapping) else None
            entry = self._entries[kind].get(name) if isinstance(name, str) else None
            schema = entry.extra.get("options") if entry is not None else None
            if schema is not None:
                keys += [f"{kind}.{field}" for field in how_fields(schema)]
        return keys

    def create(self, kind: str, options: dict[str, Any], **deps: Any) -> Any:
        """Build the plugin named by options['name'] (its options checked first).

        A plugin that registered a schema (`options=Dataclass`) gets one instance of it, its
        defaults filled in: factory(options, **deps); the schema is then the only place its
        options and defaults are written. Without one: factory(**options, **deps)."""
        reg = self.check_options(kind, options)
        options = {k: v for k, v in options.items() if k != "name"}
        from xicm.core.contracts.errors import ConfigError

        schema = reg.extra.get("options")
        try:
            built = reg.factory(options_object(schema, options), **deps) if schema is not None else reg.factory(**options, **deps)
        except TypeError as exc:
            if "unexpected keyword argument" not in str(exc):
                raise
            raise ConfigError(f"{kind} '{reg.name}' got an option it does not take: {exc}") from None
        missing = missing_methods(kind, built)
        if missing:
            raise ConfigError(
                f"{kind} '{reg.name}' (plugin {reg.plugin}) built a {type(built).__name__}, which lacks "
                f"{', '.join(missing)} of the {kind} interface (xicm.core.contracts.interfaces)"
            )
        return built


def options_object(schema: type, values: dict[str, Any]) -> Any:
    """An instance of a plugin's options dataclass: `values` (checked already) over its defaults,
    converted to the fields' types, plain lists and dicts inside."""
    from omegaconf import OmegaConf

    return OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(schema), values))


def missing_methods(kind: str, obj: Any) -> list[str]:
    """The interface methods of `kind` that `obj` does not have (duck typing: no subclassing needed)."""
    from xicm.core.contracts import interfaces

    cls = {
        "simulator": interfaces.Simulator,
        "detector": interfaces.Detector,
        "encoder": interfaces.Encoder,
        "retriever": interfaces.Retriever,
        "prompt": interfaces.PromptBuilder,
        "llm": interfaces.LLM,
        "policy": interfaces.Policy,
    }.get(kind)
    if cls is None or isinstance(obj, cls):
        return []
    return sorted(m for m in cls.__abstractmethods__ if not _provides(obj, cls, m))


def _provides(obj: Any, cls: type, member: str) -> bool:
    """A method must be callable; a property (LLM.deterministic) only present."""
    if isinstance(getattr(cls, member, None), property):
        return hasattr(obj, member)
    return callable(getattr(obj, member, None))


def make_plugin_manager(load_entry_points: bool = True) -> pluggy.PluginManager:
    """DEFAULT_PLUGINS plus the `xicm` entry points that pass XICM_LOAD_PLUGINS / XICM_DISABLE_PLUGINS.

    A plugin that fails to import is left out and remembered in `pm.xicm_failed` (name ->
    reason): runs that do not use it go on, and asking for one of its names says why it is missing.
    """
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.xicm_failed = {}  # type: ignore[attr-defined]
    pm.xicm_versions = {}  # type: ignore[attr-defined]
    allowed, disabled = _env_list("XICM_LOAD_PLUGINS"), set(_env_list("XICM_DISABLE_PLUGINS") or ())
    from xicm import __version__

    for name, module in DEFAULT_PLUGINS.items():
        if not {name, module} & disabled:
            _register(pm, name, lambda module=module: importlib.import_module(module), version=__version__)
    for ep in metadata.entry_points(group="xicm") if load_entry_points else ():
        dist = getattr(ep, "dist", None)
        names = {ep.name, ep.value, getattr(dist, "name", None)}
        if names & disabled or (allowed is not None and not names & set(allowed)):
            continue
        if ep.value in DEFAULT_PLUGINS.values():  # metadata of an older xicm install listed its built-ins
            continue
        _register(pm, ep.name, ep.load, version=dist.version if dist is not None else "unknown")
    return pm


def _register(pm: pluggy.PluginManager, name: str, load: Callable[[], Any], version: str | None) -> None:
    if pm.get_plugin(name) is not None:
        pm.xicm_failed[name] = f"a second plugin is called '{name}' (only the first was loaded)"
        log.warning("plugin %s: %s", name, pm.xicm_failed[name])
        return
    try:
        pm.register(load(), name=name)
    except Exception as exc:  # noqa: BLE001 - a broken plugin must not take down the others
        pm.xicm_failed[name] = f"{type(exc).__name__}: {exc}"
        log.warning("plugin %s was not loaded: %s", name, pm.xicm_failed[name])
        return
    if version is not None:
        pm.xicm_versions[name] = version


def _env_list(var: str) -> list[str] | None:
    """A comma-separated environment variable as a list (None when unset)."""
    value = os.environ.get(var)
    if value is None:
        return None
    return [part.strip() for part in value.split(",") if part.strip()]


_default: Registry | None = None


def get_registry() -> Registry:
    """The process-wide registry (built on first use)."""
    global _default
    if _default is None:
        _default = Registry(make_plugin_manager())
    return _default


def describe_plugins(pm: pluggy.PluginManager) -> list[dict[str, Any]]:
    """Name, version and implemented hooks of every loaded plugin (logged with every run)."""
    rows = []
    for plugin in pm.get_plugins():
        name = pm.get_name(plugin) or repr(plugin)
        hooks = sorted(h.name for h in pm.get_hookcallers(plugin) or [])
        version = getattr(pm, "xicm_versions", {}).get(name) or _module_version(name)
        rows.append({"name": name, "version": version, "hooks": hooks})
    return sorted(rows, key=lambda r: r["name"])


def _module_version(module_name: str) -> str:
    top = module_name.split(".")[0]
    try:
        return metadata.version(top)
    except metadata.PackageNotFoundError:
        return "unknown"

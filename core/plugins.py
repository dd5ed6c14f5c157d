"""Loads plugins (built-in and from the `xicm` entry-point group) and looks them up by name."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Callable

import pluggy

from xicm.core import hookspecs

#: Built-in plugins. They are also declared as entry points in pyproject.toml; this list makes
#: them load even when the package metadata is stale (e.g. a source checkout on sys.path).
BUILTIN_PLUGINS = (
    "xicm.plugins.simulators.sapien",
    "xicm.plugins.detectors.oracle",
    "xicm.plugins.retrievers.random",
    "xicm.plugins.retrievers.similarity",
    "xicm.plugins.encoders.minilm",
    "xicm.plugins.prompts.xicm_prompt",
    "xicm.plugins.llms.transformers_local",
    "xicm.plugins.llms.openai_compatible",
    "xicm.plugins.llms.nearest_demo",
    "xicm.plugins.policies.xicm",
    "xicm.plugins.policies.oracle",
)

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
        self._entries: dict[str, dict[str, Registration]] = {kind: {} for kind in KINDS}
        for kind, hook_name in KINDS.items():
            hook = getattr(pm.hook, hook_name)
            for impl in hook.get_hookimpls():
                plugin_name = pm.get_name(impl.plugin) or repr(impl.plugin)
                impl.function(register=self._register_fn(kind, plugin_name))

    def _register_fn(self, kind: str, plugin_name: str):
        def register(name: str, factory: Callable[..., Any], **extra: Any) -> None:
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
            raise UnknownPluginError(f"unknown {kind} '{name}'; available: {available}") from None

    def create(self, kind: str, options: dict[str, Any], **deps: Any) -> Any:
        """Build the plugin named by options['name'] with the remaining options."""
        options = dict(options)
        if "name" not in options:
            raise UnknownPluginError(f"the {kind} config has no 'name'; available: {', '.join(self.names(kind))}")
        reg = self.get(kind, options.pop("name"))
        try:
            return reg.factory(**options, **deps)
        except TypeError as exc:
            if "unexpected keyword argument" not in str(exc):
                raise
            from xicm.core.errors import ConfigError

            raise ConfigError(f"{kind} '{reg.name}' got an option it does not take: {exc}") from None


def make_plugin_manager(load_entry_points: bool = True) -> pluggy.PluginManager:
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    if load_entry_points:
        pm.load_setuptools_entrypoints("xicm")
    for module_name in BUILTIN_PLUGINS:
        if pm.get_plugin(module_name) is None and not _is_registered_module(pm, module_name):
            pm.register(importlib.import_module(module_name), name=module_name)
    return pm


def _is_registered_module(pm: pluggy.PluginManager, module_name: str) -> bool:
    return any(getattr(p, "__name__", None) == module_name for p in pm.get_plugins())


_default: Registry | None = None


def get_registry() -> Registry:
    """The process-wide registry (built on first use)."""
    global _default
    if _default is None:
        _default = Registry(make_plugin_manager())
    return _default


def reset_registry() -> None:
    """Forget the cached registry (tests that register throwaway plugins call this)."""
    global _default
    _default = None


def describe_plugins(pm: pluggy.PluginManager) -> list[dict[str, Any]]:
    """Name, version and implemented hooks of every loaded plugin (logged with every run)."""
    rows = []
    for plugin in pm.get_plugins():
        name = pm.get_name(plugin) or repr(plugin)
        hooks = sorted(h.name for h in pm.get_hookcallers(plugin) or [])
        dist = next((d for p, d in pm.list_plugin_distinfo() if p is plugin), None)
        version = dist.version if dist is not None else _module_version(name)
        rows.append({"name": name, "version": version, "hooks": hooks})
    return sorted(rows, key=lambda r: r["name"])


def _module_version(module_name: str) -> str:
    top = module_name.split(".")[0]
    try:
        return metadata.version(top)
    except metadata.PackageNotFoundError:
        return "unknown"

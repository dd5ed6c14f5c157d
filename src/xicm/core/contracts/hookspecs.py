"""The hooks a plugin may implement. Each hands the plugin a `register(name, factory)` callback.

A factory is called as `factory(**options)` with the options of the chosen config (minus
`name`); simulator factories also get `tasks=` (name -> task class of every task registered
for that simulator: Registry.create_simulator), retriever factories `encoder=`, policy
factories `context=` (a xicm.core.contracts.interfaces.PolicyContext: the run's config, the registry
and the live simulator). It returns an instance of the matching class in
xicm.core.contracts.interfaces. A task is registered as a class (or a stand-in with the same
attributes, called like it) whose `split`, `instruction` and `object_names` attributes give
its TaskInfo; only the simulator named by `simulator=` loads it.
"""

import pluggy

hookspec = pluggy.HookspecMarker("xicm")
hookimpl = pluggy.HookimplMarker("xicm")


@hookspec
def register_simulators(register):
    """Register simulator factories: register(name, factory); factories receive tasks=."""


@hookspec
def register_tasks(register):
    """Register tasks: register(name, task_class, simulator=NAME); simulator NAME's factory receives it in tasks=."""


@hookspec
def register_detectors(register):
    """Register detector factories: register(name, factory)."""


@hookspec
def register_encoders(register):
    """Register dynamics/text encoder factories: register(name, factory)."""


@hookspec
def register_retrievers(register):
    """Register retriever factories: register(name, factory); factories receive encoder=."""


@hookspec
def register_prompt_builders(register):
    """Register prompt builder factories: register(name, factory)."""


@hookspec
def register_llms(register):
    """Register LLM factories: register(name, factory)."""


@hookspec
def register_policies(register):
    """Register policy factories: register(name, factory); factories receive context=."""

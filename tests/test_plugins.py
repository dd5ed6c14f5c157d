import inspect
import subprocess
import sys
from unittest import mock

import pytest
from omegaconf import OmegaConf

import xicm

from xicm.core.contracts import hookspecs
from xicm.core.assembly import plugins
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.types import TaskInfo


class Echo:
    deterministic = True

    def __init__(self, reply="[[1, 2, 3, 4, 5, 6, 1]]"):
        self.reply = reply

    def complete(self, prompt):
        return self.reply


class ThrowawayPlugin:
    """A plugin defined in a test, registered and removed again."""

    @hookimpl
    def register_llms(self, register):
        register("echo_for_test", Echo)
        register("not_an_llm", lambda: "a string")
        register("undeclared_llm", lambda: type("Undeclared", (), {"complete": lambda self, p: "ok"})())


@pytest.fixture
def registry():
    pm = plugins.make_plugin_manager()
    return plugins.Registry(pm)


def test_builtin_families_are_populated(registry):
    assert "sapien" in registry.names("simulator")
    assert {"open_drawer", "push_buttons", "close_microwave"} <= set(registry.names("task"))
    assert "oracle" in registry.names("detector")
    assert {"random", "similarity"} <= set(registry.names("retriever"))
    assert "minilm" in registry.names("encoder")
    assert "xicm" in registry.names("prompt")
    assert {"transformers_local", "openai_compatible", "nearest_demo"} <= set(registry.names("llm"))


def test_unknown_name_lists_what_exists(registry):
    with pytest.raises(plugins.UnknownPluginError) as err:
        registry.get("llm", "gpt-17")
    message = str(err.value)
    assert message.startswith("unknown llm 'gpt-17'; available: ")
    assert "nearest_demo" in message and "transformers_local" in message


def _with_throwaway():
    pm = plugins.make_plugin_manager()
    pm.register(ThrowawayPlugin(), name="throwaway")
    return pm


def test_a_throwaway_plugin_registers_and_unregisters():
    pm = _with_throwaway()
    plugin = pm.get_plugin("throwaway")
    reg = plugins.Registry(pm)
    assert reg.create("llm", {"name": "echo_for_test", "reply": "hi"}).complete(None) == "hi"  # duck typing is enough
    with pytest.raises(ConfigError, match=r"llm 'not_an_llm' \(plugin throwaway\) built a str, which lacks complete, deterministic of"):
        reg.create("llm", {"name": "not_an_llm"})
    with pytest.raises(ConfigError, match=r"built a Undeclared, which lacks deterministic of the llm interface"):
        reg.create("llm", {"name": "undeclared_llm"})  # the response cache reads it directly
    assert reg.get("llm", "echo_for_test").plugin == "throwaway"
    pm.unregister(plugin)
    assert "echo_for_test" not in plugins.Registry(pm).names("llm")


def test_every_built_in_llm_declares_whether_it_is_deterministic(registry):
    from xicm.core.contracts.interfaces import LLM

    for name in registry.names("llm"):
        cls = registry.get("llm", name).factory
        assert issubclass(cls, LLM) and "deterministic" not in cls.__abstractmethods__, name


def test_how_keys_are_the_configured_plugins_options_that_say_how_a_run_is_done(registry):
    cfg = OmegaConf.create({"llm": {"name": "llamacpp"}, "retriever": {"name": "random"}, "encoder": {"name": None},
                            "policy": {"name": "remote"}, "paths": {"data": "data"}})
    keys = set(registry.how_keys(cfg))
    assert {"llm.threads", "llm.parallel", "llm.speculative", "llm.draft_max", "llm.timeout_s", "policy.timeout_s"} <= keys
    # what changes a reply stays in the run's identity
    assert not {"llm.model", "llm.temperature", "llm.max_tokens", "llm.grammar", "llm.binary", "llm.server_args"} & keys
    assert registry.how_keys({"llm": {"name": "nearest_demo"}, "retriever": {"name": "random"}}) == []


def test_two_plugins_claiming_one_name_is_an_error():
    class Clash:
        @hookimpl
        def register_llms(self, register):
            register("nearest_demo", object)

    pm = plugins.make_plugin_manager()
    pm.register(Clash(), name="clash")
    with pytest.raises(plugins.PluginConflictError, match="nearest_demo"):
        plugins.Registry(pm)


class ToyTask:
    split, instruction, object_names = "level1", "poke the toy", ["toy"]


class ToyPlugin:
    """A simulator and a task of a third party, registered for each other."""

    @hookimpl
    def register_simulators(self, register):
        register("toy_sim", lambda tasks, speed=1: mock.Mock(tasks=tasks, speed=speed))

    @hookimpl
    def register_tasks(self, register):
        register("toy_task", ToyTask, simulator="toy_sim")
        register("bare_task", object, simulator="toy_sim")


def test_a_simulator_is_built_with_the_tasks_registered_for_it():
    pm = plugins.make_plugin_manager()
    pm.register(ToyPlugin(), name="toy")
    reg = plugins.Registry(pm)
    sim = reg.create_simulator({"name": "toy_sim", "speed": 2})
    assert sim.tasks == {"bare_task": object, "toy_task": ToyTask} and sim.speed == 2
    assert "toy_task" in reg.names("task") and "toy_task" not in reg.tasks(simulator="sapien")


def test_task_info_reads_the_task_class_without_a_simulator():
    pm = plugins.make_plugin_manager()
    pm.register(ToyPlugin(), name="toy")
    reg = plugins.Registry(pm)
    assert reg.task_info("toy_task") == TaskInfo("toy_task", "level1", "poke the toy", ("toy",))
    with pytest.raises(ConfigError, match=r"^task 'bare_task' has no split, instruction, object_names \(a task class"):
        reg.task_info("bare_task")


def test_a_task_registered_without_its_simulator_fails_its_plugin_by_name():
    class Lost:
        @hookimpl
        def register_tasks(self, register):
            register("lost_task", ToyTask)

    pm = plugins.make_plugin_manager()
    pm.register(Lost(), name="lost")
    reg = plugins.Registry(pm)
    assert reg.failed["lost"] == (
        "register_tasks raised TypeError: task 'lost_task' is registered without simulator=NAME (the simulator that loads it)"
    )
    assert "lost_task" not in reg.names("task") and "open_drawer" in reg.names("task")


def test_describe_plugins_gives_name_version_and_hooks(registry):
    rows = {r["name"]: r for r in plugins.describe_plugins(registry.pm)}
    assert rows["nearest_demo"]["hooks"] == ["register_llms"]
    assert rows["sapien"]["version"] == xicm.__version__


def test_every_hookspec_has_a_one_line_docstring_and_a_family():
    specs = [f for name, f in inspect.getmembers(hookspecs, inspect.isfunction) if name.startswith("register_")]
    assert len(specs) == 8
    for f in specs:
        assert f.__doc__ and "\n" not in f.__doc__.strip(), f.__name__
        assert f.__name__ in plugins.KINDS.values()


def test_xicm_plugins_command_prints_every_plugin():
    out = subprocess.run([sys.executable, "-c", "from xicm.core.assembly.cli import plugins_main; plugins_main()"], capture_output=True, text=True, check=True).stdout
    assert "nearest_demo 0.1.0: register_llms" in out
    assert "llm: " in out and "nearest_demo" in out


def test_core_and_plugin_modules_import_no_heavy_library():
    code = (
        "import sys, xicm.core.assembly.cli, xicm.core.assembly.build, xicm.core.assembly.eval_job, xicm.core.assembly.plugins as p;"
        "p.get_registry();"
        "heavy = [m for m in ('torch', 'sapien', 'transformers', 'wandb', 'diffusers', 'sentence_transformers') if m in sys.modules];"
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""


def test_an_option_the_plugin_does_not_take_is_a_config_error(registry):
    with pytest.raises(ConfigError, match="^unknown option detector.colour of detector 'oracle'; available: cameras, min_pixels$"):
        registry.create("detector", {"name": "oracle", "colour": "red"})
    with pytest.raises(ConfigError, match="^llm 'echo_for_test' got an option it does not take: .*'colour'"):
        plugins.Registry(_with_throwaway()).create("llm", {"name": "echo_for_test", "colour": "red"})  # no schema


def test_docs_list_every_hook_and_every_interface_method_with_its_signature():
    import re
    from pathlib import Path

    from xicm.core.contracts import interfaces

    doc = (Path(__file__).parents[1] / "docs" / "plugin-authors.md").read_text()
    for name, f in inspect.getmembers(hookspecs, inspect.isfunction):
        if name.startswith("register_"):
            assert f"`{name}(register)`" in doc, name
    families = [interfaces.Simulator, interfaces.Detector, interfaces.Encoder, interfaces.Retriever,
                interfaces.PromptBuilder, interfaces.LLM, interfaces.Policy]
    for cls in families:
        assert f"**{cls.__name__}**" in doc, cls.__name__
        for name, f in vars(cls).items():
            if isinstance(f, property):  # a declared value (LLM.deterministic): `name -> type`
                returns = inspect.signature(f.fget).return_annotation
                assert f"`{name} -> {returns}`" in doc, f"{cls.__name__}.{name} is not documented in docs/plugin-authors.md"
            elif callable(f) and not name.startswith("_"):
                sig = str(inspect.signature(f)).replace("'", "")
                sig = re.sub(r"^\(self,? ?", "(", sig)
                assert f"`{name}{sig}`" in doc, f"{cls.__name__}.{name}{sig} is not documented in docs/plugin-authors.md"



def _fake_distribution(root, dist, module, source, entry_points):
    """A plugin package 'installed' into `root` (a folder put on sys.path): module + dist-info."""
    (root / f"{module}.py").write_text(source)
    info = root / f"{dist}-0.3.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.3\n")
    (info / "entry_points.txt").write_text("[xicm]\n" + "".join(f"{n} = {v}\n" for n, v in entry_points.items()))


@pytest.fixture
def third_party(tmp_path, monkeypatch):
    _fake_distribution(tmp_path, "xicm_broken", "xicm_broken", "import no_such_module_anywhere\n", {"broken": "xicm_broken"})
    _fake_distribution(
        tmp_path, "xicm_raises", "xicm_raises",
        "from xicm.core.contracts.hookspecs import hookimpl\n@hookimpl\ndef register_llms(register):\n    raise RuntimeError('no licence key')\n",
        {"raises": "xicm_raises"},
    )
    _fake_distribution(
        tmp_path, "xicm_good", "xicm_good",
        "from xicm.core.contracts.hookspecs import hookimpl\nclass Parrot:\n    deterministic = True\n    def complete(self, prompt):\n        return 'ok'\n"
        "@hookimpl\ndef register_llms(register):\n    register('parrot', Parrot)\n",
        {"good": "xicm_good"},
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    for var in ("XICM_LOAD_PLUGINS", "XICM_DISABLE_PLUGINS"):
        monkeypatch.delenv(var, raising=False)
    return monkeypatch


def test_broken_third_party_plugins_are_named_and_do_not_stop_the_others(third_party):
    reg = plugins.Registry(plugins.make_plugin_manager())
    assert reg.failed["broken"].startswith("ModuleNotFoundError: No module named 'no_such_module_anywhere'")
    assert reg.failed["raises"] == "register_llms raised RuntimeError: no licence key"
    assert reg.create("llm", {"name": "parrot"}).complete(None) == "ok"
    assert "nearest_demo" in reg.names("llm") and "sapien" in reg.names("simulator")
    rows = {r["name"]: r for r in plugins.describe_plugins(reg.pm)}
    assert rows["good"]["version"] == "0.3"
    with pytest.raises(plugins.UnknownPluginError, match=r"unknown llm 'x'; .*plugin broken failed to load \(ModuleNotFoundError"):
        reg.get("llm", "x")


def test_load_and_disable_lists_choose_the_plugins(third_party):
    third_party.setenv("XICM_LOAD_PLUGINS", "xicm_good")  # a distribution name; built-ins always load
    reg = plugins.Registry(plugins.make_plugin_manager())
    assert reg.failed == {} and "parrot" in reg.names("llm") and "nearest_demo" in reg.names("llm")
    third_party.setenv("XICM_LOAD_PLUGINS", "")
    assert "parrot" not in plugins.Registry(plugins.make_plugin_manager()).names("llm")
    third_party.delenv("XICM_LOAD_PLUGINS")
    third_party.setenv("XICM_DISABLE_PLUGINS", "broken, raises, nearest_demo")
    reg = plugins.Registry(plugins.make_plugin_manager())
    assert reg.failed == {} and "parrot" in reg.names("llm") and "nearest_demo" not in reg.names("llm")


def test_a_third_party_plugin_reusing_a_built_in_name_is_left_out_and_named(tmp_path, monkeypatch):
    source = "from xicm.core.contracts.hookspecs import hookimpl\n@hookimpl\ndef register_llms(register):\n    register('clash', object)\n"
    _fake_distribution(tmp_path, "xicm_clash", "xicm_clash", source, {"sapien": "xicm_clash"})
    monkeypatch.syspath_prepend(str(tmp_path))
    for var in ("XICM_LOAD_PLUGINS", "XICM_DISABLE_PLUGINS"):
        monkeypatch.delenv(var, raising=False)
    reg = plugins.Registry(plugins.make_plugin_manager())
    assert reg.failed == {"sapien": "a second plugin is called 'sapien' (only the first was loaded)"}
    assert "clash" not in reg.names("llm") and "sapien" in reg.names("simulator")

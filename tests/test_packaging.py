import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "xicm"  # the src layout: pyproject's package-dir = {"" = "src"}


def test_every_python_package_folder_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    assert tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"] == {"": "src"}
    assert not (ROOT / "__init__.py").exists()  # the repository root is no package
    found = set()
    for init in PACKAGE.rglob("__init__.py"):
        if "assets" in init.parts:
            continue
        found.add(".".join(("xicm", *init.parent.relative_to(PACKAGE).parts)))
    assert "xicm" in found and found == listed


def test_conf_yaml_files_are_covered_by_package_data():
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["xicm.conf"]
    conf = ROOT / "src/xicm/conf"
    yamls = {p.relative_to(conf) for p in conf.rglob("*.yaml")}
    covered = {p.relative_to(conf) for g in globs for p in conf.glob(g)}
    assert yamls and yamls == covered


def test_default_plugins_name_existing_modules_and_are_not_also_entry_points():
    from xicm.core.assembly.plugins import DEFAULT_PLUGINS

    assert "entry-points" not in tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    for module in DEFAULT_PLUGINS.values():
        rel = module.removeprefix("xicm.").replace(".", "/")
        assert (PACKAGE / f"{rel}.py").exists() or (PACKAGE / rel / "__init__.py").exists(), module


@pytest.mark.slow
@pytest.mark.pip
def test_a_wheel_install_carries_configs_assets_and_plugins(tmp_path):
    """Build the wheel, install it into a bare folder and compose the config from there."""
    import subprocess
    import sys
    import zipfile

    import shutil

    had_build_dir = (ROOT / "build").exists()
    try:
        subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(tmp_path), str(ROOT)], check=True)
    finally:
        if not had_build_dir:  # setuptools builds in-tree; leave no stale copies for later wheels
            shutil.rmtree(ROOT / "build", ignore_errors=True)
    wheel = next(tmp_path.glob("xicm-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert "xicm/conf/config.yaml" in names and "xicm/conf/llm/gemma3_270m.yaml" in names
    assert {"xicm/report/paper_table2.yaml", "xicm/report/xicm_logs.yaml", "xicm/report/templates/run.html.j2", "xicm/report/templates/sweep.html.j2"} <= set(names)
    assert any(n.startswith("xicm/plugins/simulators/sapien/assets/panda/") and n.endswith(".urdf") for n in names)
    assert not any(n.startswith(("xicm/tests/", "xicm/.venv/")) for n in names)
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target), str(wheel)], check=True)
    code = (
        "import xicm, xicm.core.assembly.plugins as p; from hydra import compose, initialize_config_module;"
        "initialize_config_module(config_module='xicm.conf', version_base='1.3').__enter__();"
        "cfg = compose('config', overrides=['llm=gemma3_270m']);"
        "print(xicm.__file__); print(cfg.llm.name); print(','.join(p.get_registry().names('task')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env={"PYTHONPATH": str(target), "PATH": ""}, check=True)
    lines = out.stdout.splitlines()
    assert lines[0].startswith(str(target)), lines[0]
    assert lines[1] == "transformers_local"
    assert "close_microwave" in lines[2].split(",")

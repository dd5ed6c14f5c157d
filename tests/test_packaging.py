import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_python_package_folder_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {"xicm"}
    for top in ("core", "plugins", "conf"):
        for init in (ROOT / top).rglob("__init__.py"):
            if "assets" in init.parts:
                continue
            rel = init.parent.relative_to(ROOT)
            found.add("xicm." + ".".join(rel.parts))
    assert found == listed


def test_conf_yaml_files_are_covered_by_package_data():
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["xicm.conf"]
    conf = ROOT / "conf"
    yamls = {p.relative_to(conf) for p in conf.rglob("*.yaml")}
    covered = {p.relative_to(conf) for g in globs for p in conf.glob(g)}
    assert yamls and yamls == covered


def test_entry_points_name_existing_modules():
    eps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]["xicm"]
    for module in eps.values():
        rel = module.removeprefix("xicm.").replace(".", "/")
        assert (ROOT / f"{rel}.py").exists() or (ROOT / rel / "__init__.py").exists(), module

"""README's layout section and DESIGN.md's module list are what scripts/readme_layout.py writes
from the tree's docstrings (run it after adding, moving or re-describing a module)."""

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "readme_layout.py"


@pytest.fixture(scope="module")
def layout():
    spec = importlib.util.spec_from_file_location("readme_layout", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", ["README.md", "docs/DESIGN.md"])
def test_the_layout_sections_are_what_the_script_writes(layout, name):
    old, new = layout.rewritten(name)
    assert old == new, f"{name}'s layout section is stale: run python scripts/readme_layout.py"


def test_every_package_folder_and_module_has_its_line(layout):
    readme = (layout.ROOT / "README.md").read_text()
    design = (layout.ROOT / "docs/DESIGN.md").read_text()
    for folder in ("src/xicm", "src/xicm/core", "src/xicm/core/contracts", "src/xicm/plugins/policies/xicm", "src/xicm/report", "src/xicm/serving", "src/xicm/vla", "src/xicm/export", "src/xicm/lerobot", "tests"):
        assert f"\n{folder}/ " in readme, folder
    for module in ("src/xicm/report/summary.py", "src/xicm/lerobot/env.py", "src/xicm/plugins/policies/xicm/llm_cache.py", "src/xicm/core/contracts/spaces.py"):
        assert f"\n  {Path(module).name} " in design.split(f"\n{Path(module).parent}/ ", 1)[1], module


def test_a_stale_section_is_found_then_rewritten(layout, tmp_path, capsys):
    for name in layout.MARKERS:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text((layout.ROOT / name).read_text().replace("\nsrc/xicm/report/ ", "\nreports/ ", 1))
    assert layout.main(["--check"], docs_root=tmp_path) == 1
    assert capsys.readouterr().err == "stale layout section in README.md, docs/DESIGN.md: run python scripts/readme_layout.py\n"
    assert layout.main([], docs_root=tmp_path) == 0 and layout.main(["--check"], docs_root=tmp_path) == 0
    for name in layout.MARKERS:
        assert (tmp_path / name).read_text() == (layout.ROOT / name).read_text()


def test_a_file_without_its_markers_is_refused_in_one_sentence(layout, tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "README.md").write_text("# xicm\n\n## Layout\n")
    with pytest.raises(SystemExit, match="^README.md needs the lines '<!-- layout: .*' and '<!-- /layout -->' once each"):
        layout.main(["--check"], docs_root=tmp_path)

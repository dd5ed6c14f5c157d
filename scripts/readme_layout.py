"""Write the layout sections of README.md (folders) and docs/DESIGN.md (modules) from the tree.

Each line is a folder or module and the first sentence of its docstring (a package's is its
__init__.py's), so the sections change when the code does: edit the docstring, then run

    python scripts/readme_layout.py           # rewrite both sections
    python scripts/readme_layout.py --check   # exit 1, naming the file, when a section is stale

tests/test_readme_layout.py runs the check. Folders without Python (tests/, docs/ ...) take
their line from FOLDERS_WITHOUT_PACKAGE below.
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the package's top folders, in the order the sections list them
PACKAGE = "src/xicm"  # the package itself (src layout); then its top folders
PACKAGES = ("src/xicm/core", "src/xicm/plugins", "src/xicm/conf", "src/xicm/report", "src/xicm/serving", "src/xicm/vla", "src/xicm/export", "src/xicm/lerobot")
#: folders below a package that hold one module per entry of a catalogue (their parent describes them)
CATALOGUES = ("src/xicm/plugins/simulators/sapien/tasks/seen", "src/xicm/plugins/simulators/sapien/tasks/unseen", "src/xicm/plugins/simulators/sapien/assets")
FOLDERS_WITHOUT_PACKAGE = {
    "tests": "The pytest suite (`-m \"not slow\"`: the fast lane; see Tests) and its helpers (tiny models, a kinematic simulator)",
    "benchmarks": "Scripts that print performance figures (not timed tests)",
    "scripts": "Set-up, main job and tests (setup.sh, main.sh, test.sh), and readme_layout.py, which writes this section",
    "docs": "The design (DESIGN.md), a guide per track (guides/), the plugin author's guide (plugin-authors.md) and the reference pages (reference/)",
    "examples": "xicm-object-overlap: an external plugin package (entry point + conf via a Hydra SearchPathPlugin)",
}
MARKERS = {  # file -> (begin, end) lines around its generated block
    "README.md": ("<!-- layout: written by scripts/readme_layout.py from the docstrings -->", "<!-- /layout -->"),
    "docs/DESIGN.md": ("<!-- modules: written by scripts/readme_layout.py from the docstrings -->", "<!-- /modules -->"),
}
WIDTH = 110
INDENT = 43  # the description column


def first_sentence(path: Path) -> str:
    """The first sentence of a module's docstring (its first paragraph up to '. ', not after e.g. or i.e.)."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
    if not doc:
        raise SystemExit(f"{path.relative_to(ROOT)} has no docstring: the layout sections take their lines from docstrings")
    paragraph = " ".join(doc.split("\n\n")[0].split())
    return re.split(r"(?<!\be\.g\.)(?<!\bi\.e\.)(?<=[.!?])\s+", paragraph)[0].rstrip(".:")


def packages() -> list[Path]:
    """The package folder, then every package folder (one with __init__.py) under PACKAGES, parents before children."""
    found = [Path(PACKAGE)]
    for top in PACKAGES:
        for init in sorted((ROOT / top).rglob("__init__.py")):
            folder = init.parent.relative_to(ROOT)
            if not any(str(folder).startswith(c) for c in CATALOGUES):
                found.append(folder)
    return found


def _line(name: str, text: str, indent: int) -> list[str]:
    head = f"{name:<{indent}}"
    return textwrap.wrap(text, WIDTH, initial_indent=head, subsequent_indent=" " * indent, break_on_hyphens=False)


def folders_block() -> str:
    """README's section: every package folder, then the folders without Python."""
    lines = []
    for folder in packages():
        lines += _line(f"{folder}/", first_sentence(ROOT / folder / "__init__.py"), INDENT)
    for name, text in FOLDERS_WITHOUT_PACKAGE.items():
        lines += _line(f"{name}/", text, INDENT)
    return "```\n" + "\n".join(lines) + "\n```"


def modules_block() -> str:
    """DESIGN.md's section: each package folder and, below it, each of its modules."""
    lines = []
    for folder in packages():
        lines += _line(f"{folder}/", first_sentence(ROOT / folder / "__init__.py"), INDENT)
        for module in sorted((ROOT / folder).glob("*.py")):
            if module.name != "__init__.py":
                lines += _line(f"  {module.name}", first_sentence(module), INDENT)
    return "```\n" + "\n".join(lines) + "\n```"


BLOCKS = {"README.md": folders_block, "docs/DESIGN.md": modules_block}


def rewritten(name: str, docs_root: Path = ROOT) -> tuple[str, str]:
    """(the file's text now, its text with the generated block written); `docs_root` holds the file."""
    text = (docs_root / name).read_text(encoding="utf-8")
    begin, end = MARKERS[name]
    if text.count(begin) != 1 or text.count(end) != 1:
        raise SystemExit(f"{name} needs the lines {begin!r} and {end!r} once each around its layout block")
    head, rest = text.split(begin + "\n", 1)
    _, tail = rest.split(end, 1)
    return text, f"{head}{begin}\n{BLOCKS[name]()}\n{end}{tail}"


def main(argv: list[str] | None = None, docs_root: Path = ROOT) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="only say which file's section differs (exit 1)")
    args = parser.parse_args(argv)
    stale = []
    for name in BLOCKS:
        old, new = rewritten(name, docs_root)
        if old != new:
            stale.append(name)
            if not args.check:
                (docs_root / name).write_text(new, encoding="utf-8")
    if stale and args.check:
        print(f"stale layout section in {', '.join(stale)}: run python scripts/readme_layout.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

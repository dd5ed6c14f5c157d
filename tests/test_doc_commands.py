"""Every `xicm-eval` and `xicm-collect` command in the README's and the guides' shell blocks still
composes and passes its command's check phase (the keys, the plugins and their options, the
tasks): a renamed option, group or preset fails here, not in a newcomer's terminal. What a
command needs on disk (a pool, a model's weights) is not there in a fresh checkout, so those
checks are the one part left out; running a command whole is the job of the main job and the
end-to-end tests."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs" / "guides").glob("*.md"))]
COMMANDS = ("xicm-eval", "xicm-collect")
SHELL_OPS = {"&&", "||", "|", ";", "&"}


def shell_blocks(text: str) -> list[str]:
    return re.findall(r"```(?:bash|sh)\n(.*?)```", text, flags=re.S)


def command_lines(block: str) -> list[list[str]]:
    """The xicm-eval / xicm-collect invocations of a block, as argument lists (comments cut,
    continuations joined, shell variables replaced by a placeholder path)."""
    joined = re.sub(r"\\\n\s*", " ", block)
    found = []
    for line in joined.splitlines():
        line = re.sub(r"\$\{?\w+\}?", "/tmp/doc-var", line)
        try:
            tokens = shlex.split(line, comments=True)
        except ValueError:
            continue
        while tokens:
            if tokens[0] in COMMANDS:
                end = next((i for i, t in enumerate(tokens) if t in SHELL_OPS), len(tokens))
                found.append(tokens[:end])
                tokens = tokens[end:]
            else:
                tokens = tokens[1:]
    return found


def split_sweep(value: str) -> list[str]:
    """`a,b` -> [a, b]; commas inside brackets or quotes (a list value) do not split."""
    parts, depth, current = [], 0, ""
    for ch in value:
        depth += ch in "[{(" and 1 or 0
        depth -= ch in "]})" and 1 or 0
        if ch == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += ch
    return [*parts, current]


def single_runs(args: list[str]) -> list[list[str]]:
    """The overrides of each job a command launches: without -m one; with -m each sweep value
    once (the other overrides at their first value)."""
    overrides = [a for a in args[1:] if a not in ("-m", "--multirun")]
    if len(overrides) == len(args) - 1:
        return [overrides]
    choices = [[key + "=" + v for v in split_sweep(value)] if sep else [key] for key, sep, value in
               (o.partition("=") for o in overrides)]
    first = [c[0] for c in choices]
    return [first, *[[*first[:i], choice, *first[i + 1:]] for i, c in enumerate(choices) for choice in c[1:]]]


def documented() -> list[tuple[str, str, list[str]]]:
    out = []
    for page in PAGES:
        for block in shell_blocks(page.read_text()):
            for args in command_lines(block):
                if any("..." in a or "<" in a for a in args):  # a placeholder for the reader to fill
                    continue
                for overrides in single_runs(args):
                    out.append((page.relative_to(ROOT).as_posix(), args[0], overrides))
    return out


CASES = documented()


def test_the_pages_document_commands():
    pages = {page for page, _, _ in CASES}
    assert "README.md" in pages and "docs/guides/xicm-on-agnostos.md" in pages
    assert len(CASES) >= 20


@pytest.mark.parametrize("page, command, overrides", CASES, ids=[f"{p}:{c} {' '.join(o)}"[:120] for p, c, o in CASES])
def test_a_documented_command_composes_and_passes_its_checks(page, command, overrides, monkeypatch):
    from hydra import compose, initialize_config_module
    from omegaconf import open_dict

    from xicm.core.assembly import checks
    from xicm.core.assembly.plugins import get_registry
    from xicm.plugins.policies.xicm import parts

    monkeypatch.setattr(parts, "require_pool", lambda path: None)  # the pool is data, not in a checkout
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose(config_name="config", overrides=overrides)
    with open_dict(cfg):  # ${hydra:...} resolves only inside a Hydra app
        cfg.run_name = cfg.tracking.group = "doc-test"
    tasks = list(cfg.benchmark.get("tasks") or [])
    parts_run = checks.RUN if command == "xicm-eval" else checks.COLLECT
    checks.run_checks(parts_run, cfg, get_registry(), tasks)

"""Cached virtual environments for libraries that cannot join xicm's own (their pins clash).

An env is described by its `EnvSpec`; its folder name carries a hash of the spec, so a changed
requirement list builds a new env and an unchanged one is reused:

    <cache>/envs/<name>-<hash of the spec>/

It is built in a temp folder beside and renamed into place only after its check passed (a
half-built env is never used), under a file lock (two processes never build it at once).
Scripts run in it by path with its interpreter; they import only what the env holds.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from xicm.core.results.atomic import file_lock
from xicm.core.contracts.errors import XicmError

READY = "xicm-env-ready"  # written last inside the env: its presence means the build finished


@dataclass(frozen=True)
class EnvSpec:
    name: str
    python: str  # interpreter on PATH that makes the venv, e.g. "python3.11"
    first: tuple[str, ...] = ()  # installed first, alone (e.g. the one CPU torch wheel)
    no_deps: tuple[str, ...] = ()  # installed with --no-deps (their declared pins are too tight)
    requirements: tuple[str, ...] = ()  # installed last, with their dependencies
    constraints: tuple[str, ...] = ()  # a constraint file for every step after `first`
    check: str = "pass"  # Python run in the finished env before it counts as built

    def folder_name(self) -> str:
        text = "\n".join([self.python, *self.first, "|", *self.no_deps, "|", *self.requirements, "|", *self.constraints, "|", self.check])
        return f"{self.name}-{hashlib.sha256(text.encode()).hexdigest()[:12]}"


def env_python(spec: EnvSpec, cache: str | Path, log=print) -> Path:
    """The interpreter of `spec`'s env under `cache`, building the env first if needed."""
    final = Path(cache).expanduser() / "envs" / spec.folder_name()
    if not (final / READY).exists():
        final.parent.mkdir(parents=True, exist_ok=True)
        with file_lock(final.with_name(f".{final.name}.lock")):
            if not (final / READY).exists():  # another process may have built it meanwhile
                _build(spec, final, log)
    return final / "bin" / "python"


def _build(spec: EnvSpec, final: Path, log) -> None:
    base = shutil.which(spec.python)
    if base is None:
        raise XicmError(f"cannot build the {spec.name} environment: there is no `{spec.python}` on PATH")
    tmp = final.with_name(f".{final.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)  # the leftover of a killed build
    shutil.rmtree(final, ignore_errors=True)  # a folder without READY is not an env
    build_log = final.with_name(f"{final.name}.build.log")
    build_log.unlink(missing_ok=True)
    start = time.perf_counter()
    log(f"building the {spec.name} environment in {final} (once per machine)")
    try:
        _run(spec, [base, "-m", "venv", str(tmp)], build_log)
        python = str(tmp / "bin" / "python")
        pip = [python, "-m", "pip", "install", "--disable-pip-version-check"]
        env = dict(os.environ)
        if spec.first:
            _run(spec, [*pip, *spec.first], build_log)
        if spec.constraints:
            (tmp / "constraints.txt").write_text("\n".join(spec.constraints) + "\n")
            env["PIP_CONSTRAINT"] = str(tmp / "constraints.txt")
        if spec.no_deps:
            _run(spec, [*pip, "--no-deps", *spec.no_deps], build_log, env)
        if spec.requirements:
            _run(spec, [*pip, *spec.requirements], build_log, env)
        _run(spec, [python, "-P", "-c", spec.check], build_log, env)  # -P: the cwd (maybe one holding a folder named lerobot) off sys.path
        (tmp / READY).write_text(f"built in {time.perf_counter() - start:.0f} s\n")
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    log(f"{spec.name} environment ready ({time.perf_counter() - start:.0f} s); build log: {build_log}")


def _run(spec: EnvSpec, cmd: list[str], build_log: Path, env: dict | None = None) -> None:
    with open(build_log, "a") as out:
        out.write(f"$ {' '.join(cmd)}\n")
        out.flush()
        done = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, env=env)
    if done.returncode != 0:
        tail = build_log.read_text(errors="replace").strip().splitlines()[-1:] or [""]
        raise XicmError(f"building the {spec.name} environment failed at `{' '.join(cmd[-3:])}` ({tail[0].strip()}); full output in {build_log}")

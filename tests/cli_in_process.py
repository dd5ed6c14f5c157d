"""Run a console script's main in this process, as `xicm-<name> args...` from `cwd` would: the
exit status, stdout and stderr of a subprocess, without paying a new interpreter, Hydra and the
plugin imports for each error message. tests/test_cli_e2e.py keeps the real subprocesses."""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass
from typing import Callable


@dataclass
class Finished:
    returncode: int
    stdout: str
    stderr: str


def run_main(main: Callable[[], None], name: str, *args: str, cwd, monkeypatch, capsys) -> Finished:
    from hydra.core.global_hydra import GlobalHydra

    monkeypatch.setattr(sys, "argv", [name, *args])
    monkeypatch.chdir(cwd)
    capsys.readouterr()  # drop what the test printed before
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    try:
        main()
        code = 0
    except SystemExit as exit_:
        code = exit_.code if isinstance(exit_.code, int) else (0 if exit_.code is None else 1)
    finally:
        GlobalHydra.instance().clear()  # as a fresh process has it
        _restore_root_logger(handlers, level)
    out = capsys.readouterr()
    return Finished(code, out.out, out.err)


def _restore_root_logger(handlers: list[logging.Handler], level: int) -> None:
    """Hydra's job logging gives the root logger a handler on this test's captured stdout (closed
    once the test ends) and one on the run's .log file; a record logged later in this process, by
    another test's thread, would hit the closed stream ("--- Logging error ---")."""
    root = logging.getLogger()
    for handler in root.handlers:
        if handler not in handlers:
            handler.close()
    root.handlers[:] = handlers
    root.setLevel(level)

"""Atomic writes: a reader (or a run killed half-way) sees the old file or folder or the new one,
never part of one. Used for every run file (src/xicm/core/results/run_dir.py) and by plugins for their caches
and checkpoints."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

_UMASK = os.umask(0)
os.umask(_UMASK)
FILE_MODE = 0o666 & ~_UMASK  # what open() would give: mkstemp's files are private (0600)


def write_atomic(path: Path, data: str | bytes | Callable[[IO[bytes]], None]) -> None:
    """Replace `path` with `data`: text (UTF-8), bytes, or a function that writes to the open
    binary file (e.g. numpy.save). The data goes to a temp file in the same folder, is flushed
    and fsynced, then renamed over `path`; if anything fails the temp file is removed and
    `path` is left as it was."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            if callable(data):
                data(f)
            else:
                f.write(data.encode("utf-8") if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_json_atomic(path: Path, data: Any, indent: int = 2) -> None:
    """`data` as indented UTF-8 JSON (values JSON lacks, e.g. paths, as their str())."""
    write_atomic(path, json.dumps(data, indent=indent, ensure_ascii=False, default=str))


def write_dir_atomic(final: Path, write: Callable[[Path], None]) -> None:
    """write(folder) fills a fresh folder beside `final`, which then takes `final`'s place (an
    older `final` is renamed aside first and deleted after). The temp folder has a fixed name,
    so the leftover of a killed attempt is removed by the next one instead of piling up."""
    final = Path(final)
    tmp, old = final.with_name(f".{final.name}.tmp"), final.with_name(f".{final.name}.old")
    for leftover in (tmp, old):
        shutil.rmtree(leftover, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        write(tmp)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if final.exists():
        os.replace(final, old)
    os.replace(tmp, final)
    shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def file_lock(path: Path):
    """Hold an exclusive lock on `path` (created if missing) for the block: processes that
    build the same cached thing (a converted model, an isolated env) take turns."""
    import fcntl

    with open(path, "a+") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)

"""The demonstration pool on disk: one HDF5 file (layout in docs/DATASET.md).

Writing is crash-safe per demo: a demo is written inside a temporary group under
/_incomplete and moved to /demos/<demo_id> only when all its datasets are written, then the
file is flushed. A killed writer therefore never leaves a half demo where readers look;
the next DemoWriter deletes the leftovers. An attempt log (/attempts) records every
collection attempt, successful or not, so a resumed collection does not retry failures.

h5py is imported inside the functions so `import xicm.core` stays light.
"""

from __future__ import annotations

import datetime as _dt
import uuid
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from xicm.core import __version__
from xicm.core.text import encoding
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.types import Box, Demo, KeyAction, Trajectory

FORMAT = "xicm-demos"
FORMAT_VERSION = 1
DEMOS = "demos"
INCOMPLETE = "_incomplete"
ATTEMPTS = "attempts"

def demo_id(task: str, seed: int, episode: int) -> str:
    """The id (and HDF5 path below /demos) of a demo: '{task}/s{seed}/e{episode:04d}'."""
    if not task or "/" in task:
        raise ValueError(f"a task name must be non-empty and contain no '/': {task!r}")
    return f"{task}/s{int(seed)}/e{int(episode):04d}"


def require_pool(path: str | Path) -> Path:
    """The pool's path, or ConfigError saying what to run when there is no file there."""
    path = Path(path)
    if not path.exists():
        raise ConfigError(
            f"no demonstration pool at {path}; run `xicm-collect benchmark=<name>` first "
            "(it writes pools/<benchmark.pool>.h5 under paths.data)"
        )
    return path


def _str(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _attempt_dtype():
    import h5py

    return np.dtype(
        [
            ("task", h5py.string_dtype()),
            ("seed", "<i8"),
            ("episode", "<i8"),
            ("success", "u1"),
            ("error", "u1"),
            ("note", h5py.string_dtype()),
        ]
    )


class Attempt(NamedTuple):
    """One logged collection attempt. error: it ended with an exception (retried on resume)."""

    success: bool
    error: bool
    note: str


class DemoWriter:
    """Appends demos to a pool file; use as a context manager.

    >>> with DemoWriter("pool.h5", workspace) as w:
    ...     if not w.has(demo.demo_id):
    ...         w.write(demo)
    """

    def __init__(self, path: str | Path, workspace: Box):
        self.path = Path(path)
        self.workspace = (tuple(float(v) for v in workspace[0]), tuple(float(v) for v in workspace[1]))
        self._file = None

    # ------------------------------------------------------------ lifecycle
    def __enter__(self) -> "DemoWriter":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def open(self) -> None:
        import h5py

        self.path.parent.mkdir(parents=True, exist_ok=True)
        f = h5py.File(self.path, "a")
        try:
            if "format_version" not in f.attrs:
                if len(f):
                    raise ConfigError(f"{self.path} is an HDF5 file but not an xicm demonstration pool; use another path")
                f.attrs["format"] = FORMAT
                f.attrs["format_version"] = FORMAT_VERSION
                f.attrs["workspace_low"] = np.asarray(self.workspace[0], np.float64)
                f.attrs["workspace_high"] = np.asarray(self.workspace[1], np.float64)
                f.attrs["created_by"] = f"xicm {__version__}"
                f.attrs["created_at"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
            else:
                version = int(f.attrs["format_version"])
                if version != FORMAT_VERSION:
                    raise ConfigError(f"{self.path} has pool format version {version}; this xicm writes {FORMAT_VERSION}")
                stored = (tuple(f.attrs["workspace_low"]), tuple(f.attrs["workspace_high"]))
                if not np.allclose(np.asarray(stored, float), np.asarray(self.workspace, float)):
                    raise ConfigError(
                        f"{self.path} was collected with workspace {stored}, not {self.workspace}; use another file"
                    )
            if INCOMPLETE in f:  # left by a killed writer
                del f[INCOMPLETE]
            f.require_group(DEMOS)
            if ATTEMPTS not in f:
                f.create_dataset(ATTEMPTS, shape=(0,), maxshape=(None,), dtype=_attempt_dtype(), chunks=(256,))
            f.flush()
        except BaseException:
            f.close()
            raise
        self._file = f

    def close(self) -> None:
        if self._file is not None:
            self._file.flush()
            self._file.close()
            self._file = None

    @property
    def file(self):
        if self._file is None:
            raise RuntimeError("DemoWriter is not open; use it as a context manager")
        return self._file

    # ------------------------------------------------------------ demos
    def has(self, demo_id: str) -> bool:
        return f"{DEMOS}/{demo_id}" in self.file

    def demo_ids(self) -> list[str]:
        return _demo_ids(self.file)

    def write(self, demo: Demo) -> None:
        """Write one demo; it appears under /demos only once it is complete."""
        f = self.file
        if self.has(demo.demo_id):
            raise ValueError(f"{demo.demo_id} is already in {self.path}")
        if demo.demo_id != demo_id(demo.task, demo.seed, demo.episode):
            raise ValueError(f"demo id {demo.demo_id!r} does not follow '{{task}}/s{{seed}}/e{{episode:04d}}'")
        tmp = f.require_group(INCOMPLETE).create_group(uuid.uuid4().hex)
        tmp.attrs["target"] = demo.demo_id
        _fill_group(tmp, demo, self.workspace)
        parent = demo.demo_id.rsplit("/", 1)[0]
        f.require_group(f"{DEMOS}/{parent}")
        f.move(tmp.name, f"/{DEMOS}/{demo.demo_id}")
        f.flush()

    # ------------------------------------------------------------ attempts
    def log_attempt(self, task: str, seed: int, episode: int, success: bool, note: str = "", error: bool = False) -> None:
        """Append one row to /attempts and flush."""
        ds = self.file[ATTEMPTS]
        n = ds.shape[0]
        ds.resize((n + 1,))
        row = np.zeros((), dtype=ds.dtype)
        row["task"], row["seed"], row["episode"] = task, int(seed), int(episode)
        row["success"], row["error"], row["note"] = int(bool(success)), int(bool(error)), str(note)
        ds[n] = row
        self.file.flush()

    def attempts(self) -> dict[tuple[str, int, int], Attempt]:
        """(task, seed, episode) -> Attempt of every logged attempt (the last one wins)."""
        return read_attempts(self.file)


def _fill_group(g, demo: Demo, workspace: Box) -> None:
    import h5py

    g.attrs["demo_id"] = demo.demo_id
    g.attrs["task"] = demo.task
    g.attrs["instruction"] = demo.instruction
    g.attrs["seed"] = int(demo.seed)
    g.attrs["episode"] = int(demo.episode)
    names = list(demo.objects)
    g.attrs.create("object_names", np.array(names, dtype=object).reshape(len(names)), dtype=h5py.string_dtype())
    xyz = np.asarray([demo.objects[n] for n in names], np.float32).reshape(len(names), 3)
    g.create_dataset("objects_xyz", data=xyz)
    acts = np.asarray(
        [[*a.position, *a.quat_wxyz, float(a.gripper_open)] for a in demo.key_actions], np.float32
    ).reshape(len(demo.key_actions), 8)
    g.create_dataset("key_actions", data=acts)
    ints = np.asarray([encoding.action_to_ints(a, workspace) for a in demo.key_actions], np.int16)
    g.create_dataset("key_actions_int", data=ints.reshape(len(demo.key_actions), 7))
    for name, dtype in (("first_rgb", np.uint8), ("last_rgb", np.uint8), ("first_depth", np.float32), ("last_depth", np.float32)):
        value = getattr(demo, name)
        if value is not None:
            arr = np.asarray(value, dtype)
            g.create_dataset(name, data=arr, chunks=arr.shape, compression="gzip", compression_opts=4, shuffle=True)
    t = demo.trajectory
    if t is not None:
        g.create_dataset("joint_positions", data=np.asarray(t.joint_positions, np.float32))
        g.create_dataset("joint_velocities", data=np.asarray(t.joint_velocities, np.float32))
        g.create_dataset("gripper_open", data=np.asarray(t.gripper_open, np.uint8))
        g.create_dataset("ee_poses", data=np.asarray(t.ee_poses, np.float32))


def _demo_ids(f) -> list[str]:
    """Every complete demo in an open file, sorted ('task/sSEED/eEPISODE')."""
    ids = []
    if DEMOS not in f:
        return ids
    for task, tg in f[DEMOS].items():
        for s, sg in tg.items():
            for e in sg:
                ids.append(f"{task}/{s}/{e}")
    return sorted(ids)


def read_attempts(f) -> dict[tuple[str, int, int], Attempt]:
    """The attempt log of an open pool file, last row per (task, seed, episode)."""
    out: dict[tuple[str, int, int], Attempt] = {}
    if ATTEMPTS not in f:
        return out
    for row in f[ATTEMPTS][()]:
        key = (_str(row["task"]), int(row["seed"]), int(row["episode"]))
        out[key] = Attempt(bool(row["success"]), bool(row["error"]), _str(row["note"]))
    return out


def _read_demo(g, with_images: bool, with_trajectories: bool) -> Demo:
    names = [_str(n) for n in g.attrs["object_names"]]
    xyz = g["objects_xyz"][()]
    acts = g["key_actions"][()]
    demo = Demo(
        demo_id=_str(g.attrs["demo_id"]),
        task=_str(g.attrs["task"]),
        instruction=_str(g.attrs["instruction"]),
        seed=int(g.attrs["seed"]),
        episode=int(g.attrs["episode"]),
        objects={n: tuple(float(v) for v in p) for n, p in zip(names, xyz)},
        key_actions=[
            KeyAction(tuple(float(v) for v in a[:3]), tuple(float(v) for v in a[3:7]), bool(a[7] >= 0.5)) for a in acts
        ],
    )
    if with_images:
        for name in ("first_rgb", "last_rgb", "first_depth", "last_depth"):
            if name in g:
                setattr(demo, name, g[name][()])
    if with_trajectories and "joint_positions" in g:
        demo.trajectory = Trajectory(
            joint_positions=g["joint_positions"][()],
            joint_velocities=g["joint_velocities"][()],
            gripper_open=g["gripper_open"][()].astype(bool),
            ee_poses=g["ee_poses"][()],
            success=True,
        )
    return demo


def _open_read(path: Path):
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ConfigError(f"cannot read the demonstration pool {path} ({exc}); is xicm-collect still writing it?") from exc
    if f.attrs.get("format") not in (FORMAT, FORMAT.encode()):
        f.close()
        raise ConfigError(f"{path} is not an xicm demonstration pool (no format='{FORMAT}' attribute)")
    return f


def load_pool(
    path: str | Path,
    tasks: Iterable[str] | None = None,
    with_images: bool = True,
    with_trajectories: bool = False,
) -> list[Demo]:
    """Every complete demo in the pool (of `tasks` when given), sorted by demo id.

    with_images loads first/last RGB and depth; with_trajectories loads the recorded
    control-frame trajectory (not needed for retrieval or prompting).
    """
    path = require_pool(path)
    wanted = None if tasks is None else set(tasks)
    demos = []
    with _open_read(path) as f:
        for did in _demo_ids(f):
            if wanted is not None and did.split("/", 1)[0] not in wanted:
                continue
            demos.append(_read_demo(f[f"{DEMOS}/{did}"], with_images, with_trajectories))
    return demos


def pool_info(path: str | Path) -> dict[str, Any]:
    """File attributes, the workspace and the number of demos and attempts per task."""
    path = require_pool(path)
    with _open_read(path) as f:
        attrs = {k: (_str(v) if isinstance(v, (bytes, str)) else v) for k, v in f.attrs.items()}
        ids = _demo_ids(f)
        attempts = read_attempts(f)
    demos: dict[str, int] = {}
    for did in ids:
        task = did.split("/", 1)[0]
        demos[task] = demos.get(task, 0) + 1
    tried: dict[str, int] = {}
    for task, _seed, _ep in attempts:
        tried[task] = tried.get(task, 0) + 1
    return {
        "format": attrs.get("format"),
        "format_version": int(attrs["format_version"]),
        "workspace": (tuple(float(v) for v in attrs["workspace_low"]), tuple(float(v) for v in attrs["workspace_high"])),
        "created_by": attrs.get("created_by"),
        "created_at": attrs.get("created_at"),
        "demos": demos,
        "attempts": tried,
    }


def first_frames(path: str | Path, demo_ids: Iterable[str]) -> dict[str, np.ndarray]:
    """{demo id: its first RGB frame} for the ids the pool holds (ids it lacks are left out)."""
    out = {}
    with _open_read(require_pool(path)) as f:
        for did in demo_ids:
            key = f"{DEMOS}/{did}/first_rgb"
            if key in f:
                out[did] = f[key][()]
    return out

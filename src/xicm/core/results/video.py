"""Rollout videos: one MP4 per episode from one camera, named after the episode's outcome.

The simulator calls back after every frame it steps (`Simulator.set_frame_callback`);
the recorder renders its camera on every `every`-th frame and streams the picture to an ffmpeg
process (imageio + imageio-ffmpeg), so memory stays flat however long the episode. A simulator
without that callback gets one picture per key action instead. The file is written under a
temporary name and renamed to `s<seed>-e<episode>-PASS.mp4` (or -FAIL) once the outcome is known
(the names: `RunDir.video_recording` and `RunDir.video`).

A video never fails an episode: any error (no encoder, a full disk, a camera the simulator
lacks) stops that episode's recording, is printed once per process, and is recorded in the
episode row as extra["video_error"].
"""

from __future__ import annotations

import contextlib
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from xicm.core.contracts.interfaces import Simulator
from xicm.core.results.run_dir import RunDir
from xicm.core.contracts.types import Observation

_warned = False  # the one-line warning is printed once per process


@dataclass(frozen=True)
class VideoSettings:
    """What to record and where: `<run_dir>/videos/<task>/s<seed>-e<episode:04d>-PASS.mp4`. The
    values are the run's `video` keys (config_schema.Video: their types and rules; src/xicm/conf/config.yaml:
    their defaults), so none has a default here."""

    run_dir: Path
    camera: str
    fps: float  # playback frames per second
    every: int  # render every k-th frame

    @classmethod
    def from_config(cls, video: Any, run_dir: Path) -> VideoSettings | None:
        """The settings of the run's `video` keys (cfg.video); None when videos are off."""
        if not video.enabled:
            return None
        return cls(Path(run_dir), video.camera, video.fps, video.every)

    def path(self, task: str, seed: int, episode: int, success: bool) -> Path:
        return RunDir(self.run_dir).video(task, seed, episode, success)


class EpisodeVideo:
    """Records one episode. Every public method swallows its own errors (see the module doc)."""

    def __init__(self, settings: VideoSettings, task: str, seed: int, episode: int):
        self.settings = settings
        self.task, self.seed, self.episode = task, int(seed), int(episode)
        self.run = RunDir(settings.run_dir)
        self.partial = self.run.video_recording(task, seed, episode)
        self.error: str | None = None
        self.frames = 0  # pictures written
        self.seconds = 0.0  # spent rendering and encoding
        self.seconds_in_callbacks = 0.0  # the part spent inside Simulator.execute
        self._writer = None
        self._simulator: Simulator | None = None
        self._callbacks = False  # the simulator calls us per frame
        self._control_frames = 0
        self._captured_last = True  # the state after the last frame is in the video
        self._final: Path | None = None

    # --- episode hooks -------------------------------------------------------------------------
    def start(self, simulator: Simulator, obs: Observation) -> None:
        """Open the file, write the reset picture, ask the simulator for per-frame callbacks."""
        self._simulator = simulator
        self._guard(self._open, obs)
        if self.error is None:
            attach = getattr(simulator, "set_frame_callback", None)  # duck-typed simulators may lack it
            try:
                self._callbacks = attach is not None and bool(attach(self._on_control_frame))
            except Exception as exc:  # noqa: BLE001
                self._fail(exc)

    def action_done(self) -> None:
        """After each key action: the picture for simulators that have no frame callback."""
        if not self._callbacks and self.error is None and self._writer is not None:
            self._guard(self._capture)

    def finish(self, success: bool) -> dict[str, Any]:
        """Detach, add the final state, close and rename; what goes into the row's extra."""
        self._detach()
        if self._writer is not None and self.error is None and not self._captured_last:
            self._guard(self._capture)
        self._guard(self._close)
        if self.error is None and self.frames:
            self._guard(self._publish, success)
        if self.error is not None:
            self._discard()
            return {"video_error": self.error}
        if not self.frames:
            return {}  # the episode ended before its first picture (reset failed)
        return {"video": self.run.relative(self._final), "video_frames": self.frames}

    # --- work ------------------------------------------------------------------------------------
    def _open(self, obs: Observation) -> None:
        try:
            import imageio.v2 as imageio  # heavy: only when recording
        except ImportError as exc:
            raise RuntimeError(f"rollout videos need imageio and imageio-ffmpeg: pip install 'xicm[video]' ({exc})") from None

        self.partial.parent.mkdir(parents=True, exist_ok=True)
        self._writer = imageio.get_writer(
            str(self.partial), format="FFMPEG", mode="I", fps=self.settings.fps, codec="libx264",
            pixelformat="yuv420p", macro_block_size=2, ffmpeg_log_level="error",
        )
        frame = obs.cameras.get(self.settings.camera)
        self._write(frame.rgb if frame is not None else self._render())

    def _on_control_frame(self) -> None:
        if self.error is not None or self._writer is None:
            return
        self._control_frames += 1
        self._captured_last = False
        if self._control_frames % self.settings.every == 0:
            before = self.seconds
            self._guard(self._capture)
            self.seconds_in_callbacks += self.seconds - before

    def _capture(self) -> None:
        self._write(self._render())
        self._captured_last = True

    def _render(self):
        camera = self.settings.camera
        frame = self._simulator.observe(cameras=[camera]).cameras.get(camera)
        if frame is None:
            raise ValueError(f"the simulator returned no picture from camera '{camera}'")
        return frame.rgb

    def _write(self, rgb) -> None:
        self._writer.append_data(rgb)
        self.frames += 1

    def _close(self) -> None:
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.close()

    def _publish(self, success: bool) -> None:
        """Rename to the verdict's name; drop a file an earlier, interrupted attempt left."""
        self._final = self.settings.path(self.task, self.seed, self.episode, success)
        for old in self.run.finished_videos(self.task, self.seed, self.episode):
            if old != self._final:
                old.unlink()
        self.partial.replace(self._final)

    # --- failure handling ------------------------------------------------------------------------
    def _guard(self, fn, *args) -> None:
        t0 = time.perf_counter()
        try:
            fn(*args)
        except Exception as exc:  # noqa: BLE001 - a video must never fail the episode
            self._fail(exc)
        finally:
            self.seconds += time.perf_counter() - t0

    def _fail(self, exc: BaseException) -> None:
        global _warned
        if self.error is None:
            self.error = f"{type(exc).__name__}: {exc}".splitlines()[0][:300]
        if not _warned:
            _warned = True
            print(f"xicm: warning: rollout video not recorded ({self.error}); the episodes go on", file=sys.stderr)
        self._detach()

    def _detach(self) -> None:
        if self._callbacks and self._simulator is not None:
            self._callbacks = False
            with contextlib.suppress(Exception):
                self._simulator.set_frame_callback(None)

    def _discard(self) -> None:
        with contextlib.suppress(Exception):
            self._close()
        with contextlib.suppress(OSError):
            self.partial.unlink(missing_ok=True)

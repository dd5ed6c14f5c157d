"""One xicm task as a Gymnasium environment, stepped at the simulator's control rate.

reset(seed=s, options={"episode": e}) loads the benchmark's scene (s, e): the same scene
xicm-eval evaluates as seed s, episode e (seed None: drawn from the env's generator; episode
default 0); its info names the scene (instruction, seed, episode, variation). Observations:
{"state": proprio} plus, for obs_mode "rgb", {"rgb": {camera: HxWx3}} (and "depth" for
"rgbd"). The reward is 1.0 on the step that succeeds; terminated on success,
truncated after max_control_steps (the task's default unless given). A step the simulator
refuses (unreachable, bad action) leaves the state as it was and says why in
info["error_kind"] / info["error_message"].

Any simulator plugin serves (`simulator=`): it is built with the options control_mode and render,
cameras and image_size when something is rendered, and `simulator_options`; the spaces come
from its control_spec() and image_sizes().
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from xicm.core.contracts.errors import ConfigError

OBS_MODES = ("state", "rgb", "rgbd")
SEED_RANGE = 2**31  # seeds drawn when reset gets none
FAR = 5.0  # metres: the cameras' far plane (depth is 0 where nothing was hit)


class XicmEnv(gymnasium.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        task: str,
        obs_mode: str = "rgb",
        control_mode: str = "ee_delta",
        render_mode: str | None = None,
        cameras: list[str] | tuple[str, ...] = ("front", "wrist"),
        image_size: Any = 128,
        max_control_steps: int | None = None,
        variations: str = "sampled",
        simulator: str = "sapien",
        simulator_options: dict[str, Any] | None = None,
    ):
        from xicm.core.assembly.checks import check_simulator_options
        from xicm.core.assembly.plugins import get_registry

        if obs_mode not in OBS_MODES:
            raise ConfigError(f"obs_mode must be one of {', '.join(OBS_MODES)}, not {obs_mode!r}")
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(f"render_mode must be 'rgb_array' or None, not {render_mode!r}")
        if variations not in ("zero", "sampled"):
            raise ConfigError(f"variations must be 'zero' or 'sampled', not {variations!r}")
        registry = get_registry()
        render = obs_mode != "state" or render_mode is not None
        pictures = {"cameras": list(cameras), "image_size": image_size if isinstance(image_size, (int, dict)) else list(image_size)}
        # a state-only env renders nothing: the simulator keeps its own cameras (whatever they are called)
        options = {"name": simulator, **(pictures if render else {}), "control_mode": control_mode, "render": render,
                   **(simulator_options or {})}
        check_simulator_options(registry, options)
        self.task, self.obs_mode, self.render_mode = task, obs_mode, render_mode
        self.cameras = [str(c) for c in cameras]
        self.sim = registry.create_simulator(options)
        if task not in self.sim.task_names():
            self.sim.close()
            raise ConfigError(f"unknown task {task!r}; available: {', '.join(self.sim.task_names())}")
        self.sim.sample_variations = variations == "sampled"
        info = self.sim.task_info(task)
        budget = max_control_steps or info.max_control_steps
        if budget is None:
            self.sim.close()
            raise ConfigError(f"task {task!r} declares no max_control_steps: pass max_control_steps=N")
        self.max_control_steps = int(budget)
        self.instruction = info.instruction  # variation 0's; reset sets the episode's own
        self.control_spec = self.sim.control_spec()  # the simulator's layouts: the spaces' one source
        self.action_space = _box(self.control_spec.step_mode)
        self.observation_space = self._observation_space()
        self._steps = 0
        self._frames: dict[str, Any] = {}

    # --- spaces -------------------------------------------------------------------------------
    def _observation_space(self) -> spaces.Dict:
        state = spaces.Dict({f.name: _box(f) for f in self.control_spec.state})
        parts: dict[str, spaces.Space] = {"state": state}
        if self.obs_mode != "state":
            sizes = self.sim.image_sizes()
            parts["rgb"] = spaces.Dict({c: spaces.Box(0, 255, (*sizes[c], 3), np.uint8) for c in self.cameras})
        if self.obs_mode == "rgbd":
            sizes = self.sim.image_sizes()
            parts["depth"] = spaces.Dict({c: spaces.Box(0.0, FAR, (*sizes[c], 1), np.float32) for c in self.cameras})
        return spaces.Dict(parts)

    # --- gymnasium ----------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = dict(options or {})
        scene_seed = int(seed) if seed is not None else int(self.np_random.integers(SEED_RANGE))
        episode = int(options.pop("episode", 0))
        if options:
            raise ConfigError(f"unknown reset option(s) {', '.join(sorted(options))}; reset takes 'episode'")
        self.sim.reset_state(self.task, scene_seed, episode)
        self.instruction = self.sim.instruction()
        self._steps = 0
        info = {"instruction": self.instruction, "seed": scene_seed, "episode": episode, "variation": self.sim.variation(),
                "success": False}
        return self._observe(), info

    def step(self, action):
        outcome = self.sim.step(np.asarray(action, dtype=np.float64))
        self._steps += 1
        info = {"success": bool(outcome.success), "instruction": self.instruction}
        if not outcome.ok:
            info.update(error_kind=outcome.error_kind, error_message=outcome.error_message)
        terminated = bool(outcome.success)
        truncated = not terminated and self._steps >= self.max_control_steps
        return self._observe(), float(terminated), terminated, truncated, info

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self.cameras[0] not in self._frames:
            self._frames = self.sim.observe([self.cameras[0]]).cameras
        return self._frames[self.cameras[0]].rgb.copy()

    def close(self) -> None:
        if getattr(self, "sim", None) is not None:
            self.sim.close()
            self.sim = None

    # --- observations -------------------------------------------------------------------------
    def _observe(self) -> dict[str, Any]:
        proprio = self.sim.proprio()
        obs: dict[str, Any] = {"state": {f.name: proprio[f.name].astype(np.float32) for f in self.control_spec.state}}
        self._frames = {}
        if self.obs_mode != "state":
            self._frames = self.sim.observe(self.cameras).cameras
            obs["rgb"] = {c: self._frames[c].rgb for c in self.cameras}
        if self.obs_mode == "rgbd":
            obs["depth"] = {c: self._frames[c].depth[..., None] for c in self.cameras}
        return obs


def _box(layout) -> spaces.Box:
    """A float32 Box over a layout of the simulator's ControlSpec (a control mode or a proprio field)."""
    low, high = layout.bounds()
    return spaces.Box(low, high, (layout.width,), np.float32)

"""Gymnasium environments: ``SimSerpent-v0`` and a vector environment stepped in Rust.

The observation, actions, reward and episode end are set by the config's ``[env]`` section
(see ``default_config_toml()``), following Gymnasium's MuJoCo suite (Swimmer-v5) by default:

- observation (version ``env.observation_version`` = 1): measured joint angles and velocities,
  head position (only z by default: ``env.exclude_current_positions_from_observation``),
  quaternion (w, x, y, z) and linear velocity, optionally per link IMU (``env.observe_imu``) and
  per joint force/torque sensors (``env.observe_joint_force_torque``), with the ``[sensors]``
  noise, seeded by ``reset(seed=...)``; ``env.observation_names`` names every element;
- action: a float32 box in [-1, 1] (``env.normalize_action``) mapped onto the joint target
  angles (``env.action = "position"``, +-``snake.joint_range_deg``) or joint torques
  (``"torque"``, ``snake.torque_range_nm``), one per joint, held for ``env.control_period_secs``
  (= ``env.dt``). Sign convention: see ``JOINT_SIGN_CONVENTION``;
- reset noise: uniform joint angles, normal joint velocities (``env.reset_noise_scale``) and a
  uniform heading (``env.reset_heading_noise_rad``), drawn from the episode's seed;
- reward (rates): ``reward_forward_weight`` x forward velocity - ``reward_energy_weight`` x mean
  actuator power - ``reward_contact_force_weight`` x largest contact force -
  ``reward_ctrl_cost_weight`` x sum(action^2); ``info`` has every weighted term
  (``reward_forward``, ``reward_ctrl``, ...) and ``x_position``, ``y_position``, ``x_velocity``,
  ``y_velocity``, ``distance_from_origin``, ``peak_contact_force_n`` (absent, never a fake 0,
  when the step diverged);
- contact estimates (``[estimation] enabled = true``): ``info["contact_estimates"]`` after every
  step, the dict of :meth:`simserpent.World.contact_estimates` (per link obstacle force, contact
  flag and point, from the measured sensors); with ``env.observe_contact_estimates`` also in the
  observation (per link obstacle force x, y, flag, point along the link);
- terminated: the simulation diverged (``info["error"]`` says why) or a contact force exceeded
  ``env.terminate_contact_force_n``; truncated: ``env.max_episode_secs`` reached (the physics
  goes on if you keep stepping, each step again ``truncated``; ``spec.max_episode_steps``
  says when).

Rendering (``render_mode`` ``"rgb_array"``, ``"depth_array"``, ``"human"``) draws the env's own
model at its true state with the official :class:`mujoco.Renderer` of the ``mujoco`` package
(offscreen) or :mod:`mujoco.viewer` (``"human"``, needs a display). The
simulation itself does not need the ``mujoco`` package (the wheel carries its own MuJoCo 3.17);
rendering does: ``mujoco`` 3.2 or later, 3.x or 4.x (tested with 3.17.0 and 4.0.0;
``pip install mujoco``). The camera follows the snake's centre of mass at the config's
``render.camera_distance_m``, ``render.camera_azimuth_deg`` and ``render.camera_elevation_deg``
(the CLI's framing; keyword arguments override them).

Headless by default: without a display (no ``DISPLAY`` or ``WAYLAND_DISPLAY``) and without
``MUJOCO_GL`` in the environment, importing this module (``import simserpent``) sets
``MUJOCO_GL=egl``, MuJoCo's offscreen back-end, unless ``mujoco`` was imported already (it reads
``MUJOCO_GL`` once, when it is imported); a value you set is kept. Rendering with a ``mujoco``
imported earlier with its window back-end (GLFW) and no display raises a ``RuntimeError`` that says
what to set, instead of MuJoCo aborting the process.

``metadata["render_modes"]`` of an environment lists the modes that work where it runs:
``"human"`` only with a display, ``"rgb_array"`` and ``"depth_array"`` only with the ``mujoco``
package installed (Gymnasium's ``check_env`` renders every listed mode, and Swimmer-v5, which
always lists ``"human"``, aborts in it without a display).
"""

from __future__ import annotations

import dataclasses
import json as _json
import math
import os
from typing import TYPE_CHECKING, Any, Union

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from gymnasium.envs.registration import EnvSpec
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from . import _core

if TYPE_CHECKING:
    from . import Config, ConfigLike, Overrides

#: An observation or action vector (float64; actions may be float32).
Array = npt.NDArray[np.float64]
ObsArray = npt.NDArray[np.float64]
ActArray = npt.NDArray[Any]

ENV_ID = "SimSerpent-v0"

_SEED_MAX = 2**63 - 1

#: The reward terms and read-outs in ``info`` (in the vector env: one array each).
TERM_NAMES: list[str] = list(_core.TERM_NAMES)

RENDER_MODES = ["human", "rgb_array", "depth_array"]

#: The ``mujoco`` releases rendering is tested with (the Python package draws the env's MJCF).
RENDER_MUJOCO_VERSIONS = ("3.17.0", "4.0.0")


def _config(config: ConfigLike, overrides: Overrides) -> Config:
    from . import load_config

    return load_config(config, overrides)


def _spaces(core: _core.Env) -> tuple[Any, Any]:
    """(observation space, action space): float64 boxes; a float32 box in [-1, 1] for
    normalised actions."""
    n = core.observation_size
    observation_space: Any = spaces.Box(-np.inf, np.inf, shape=(n,), dtype=np.float64)
    action_space: Any
    if core.normalize_action:
        action_space = spaces.Box(-1.0, 1.0, shape=(core.action_size,), dtype=np.float32)
    else:
        action_space = spaces.Box(core.action_low, core.action_high, dtype=np.float64)
    return observation_space, action_space


def episode_seeds(seed: int | None, count: int) -> list[int]:
    """The sensor- and reset-noise seeds of the first ``count`` episodes of an environment
    reset with ``seed`` and then reset without a seed (what :class:`SimSerpentEnv` and the
    vector env draw): the one seed -> noise mapping of every vectorisation mode."""
    rng, _ = gym.utils.seeding.np_random(seed)
    return [int(rng.integers(0, _SEED_MAX)) for _ in range(count)]


def has_display() -> bool:
    """Whether a window can be opened (an X11 or Wayland display is set)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def has_mujoco_package() -> bool:
    """Whether the ``mujoco`` Python package (which rendering uses) is installed."""
    import importlib.util

    return importlib.util.find_spec("mujoco") is not None


def available_render_modes() -> list[str]:
    """The render modes that work here: ``"human"`` needs a display and the ``mujoco`` package,
    ``"rgb_array"`` and ``"depth_array"`` the ``mujoco`` package."""
    if not has_mujoco_package():
        return []
    return [m for m in RENDER_MODES if m != "human" or has_display()]


def default_gl_backend() -> str | None:
    """Chooses MuJoCo's OpenGL back-end before the ``mujoco`` package is imported: without a
    display (no ``DISPLAY`` or ``WAYLAND_DISPLAY``) and without ``MUJOCO_GL`` set, sets
    ``MUJOCO_GL=egl`` (offscreen). A value the user set is kept, and nothing changes once
    ``mujoco`` is imported (it reads ``MUJOCO_GL`` once, at import). Returns the value in force."""
    import sys

    if "mujoco" not in sys.modules and not has_display() and not os.environ.get("MUJOCO_GL"):
        os.environ["MUJOCO_GL"] = "egl"
    return os.environ.get("MUJOCO_GL")


# Headless by default (see the module's docstring): before anyone imports `mujoco` through us.
default_gl_backend()


def _window_backend_without_display(mujoco: Any) -> bool:
    """Whether ``mujoco`` was imported with a back-end that needs a window (GLFW: ``MUJOCO_GL``
    unset or ``glfw``) while there is no display: its renderer would fail to get an OpenGL
    context and then abort the process."""
    if has_display():
        return False
    # `mujoco` exports the GLContext class of the back-end it chose at import (3.x and 4.x).
    context = getattr(mujoco, "GLContext", None)
    return context is not None and str(getattr(context, "__module__", "")).endswith("glfw")


def _mujoco_for_rendering(render_mode: str) -> Any:
    """Imports the ``mujoco`` package for rendering (offscreen EGL by default without a
    display: :func:`default_gl_backend`), with an error naming what to install if it is missing
    and what to set if it was imported with a back-end that cannot work here."""
    if render_mode != "human":
        default_gl_backend()
    try:
        import mujoco
    except ImportError:
        raise ImportError(
            f"render_mode={render_mode!r} draws with the `mujoco` package, which is not installed; "
            f"pip install mujoco (3.2 or later, 3.x or 4.x; tested: {', '.join(RENDER_MUJOCO_VERSIONS)})"
        ) from None
    if render_mode != "human" and _window_backend_without_display(mujoco):
        raise RuntimeError(
            f"render_mode={render_mode!r}: the `mujoco` package was imported with MUJOCO_GL="
            f"{os.environ.get('MUJOCO_GL', '')!r} (its window back-end, GLFW) and there is no display "
            "(DISPLAY and WAYLAND_DISPLAY are unset); set MUJOCO_GL=egl in the environment, or import "
            "simserpent before mujoco (without a display and MUJOCO_GL it sets MUJOCO_GL=egl)"
        )
    return mujoco


class MujocoRendering:
    """Draws a :class:`simserpent.World` with the official MuJoCo renderer: the world's own
    MJCF compiled by the ``mujoco`` package (the same libmujoco), its true state copied in
    (MuJoCo's integration state: time, qpos, qvel, act, ...) and a forward pass; a camera
    that follows the snake's centre of mass from above at an angle (or a camera of the model
    by name or id). The model is compiled at the first ``render()``."""

    def __init__(self, world: _core.Env, render_mode: str, width: int = 480, height: int = 480,
                 camera: str | int | None = None, distance_m: float | None = None, quality: str = "fast",
                 azimuth_deg: float = 90.0, elevation_deg: float = -35.0):
        if quality not in ("fast", "full"):
            raise ValueError(f"render quality {quality!r}: allowed 'fast' (no shadows, reflections, MSAA) or 'full'")
        self.quality = quality
        self.world = world
        self.render_mode = render_mode
        if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in (width, height)):
            raise TypeError(f"render width and height must be whole numbers of pixels, got {width!r} x {height!r}")
        self.width, self.height = int(width), int(height)
        if self.width < 1 or self.height < 1:
            raise ValueError(f"render width and height must be at least 1, got {width} x {height}")
        self._camera_arg = camera
        if distance_m is not None and not (math.isfinite(distance_m) and distance_m > 0):
            raise ValueError(f"camera_distance_m must be a positive number of metres, got {distance_m!r}")
        for name, value in (("camera_azimuth_deg", azimuth_deg), ("camera_elevation_deg", elevation_deg)):
            if not math.isfinite(value):
                raise ValueError(f"{name} must be a finite angle in degrees, got {value!r}")
        self._distance_m = distance_m
        self._azimuth_deg = float(azimuth_deg)
        self._elevation_deg = float(elevation_deg)
        self.model: Any = None
        self.data: Any = None
        self._renderer: Any = None
        self._viewer: Any = None

    def _setup(self) -> None:
        mujoco = _mujoco_for_rendering(self.render_mode)

        self._mujoco = mujoco
        try:
            self.model = mujoco.MjModel.from_xml_string(self.world.mjcf)
        except ValueError as e:  # a model with terrain files: they are not beside the text
            raise _core.ModelError(
                f"cannot compile the environment's MJCF for rendering ({e}); rendering needs a model "
                "without third-party terrain files"
            ) from None
        # The offscreen buffer must hold the picture.
        self.model.vis.global_.offwidth = max(self.model.vis.global_.offwidth, self.width)
        self.model.vis.global_.offheight = max(self.model.vis.global_.offheight, self.height)
        if self.quality == "fast":
            # SimSerpent's render.quality = "fast": no MSAA (shadows and reflections are
            # switched off in the scene below); ~10x faster on a software rasteriser.
            self.model.vis.quality.offsamples = 0
        self.data = mujoco.MjData(self.model)
        if (self.model.nq, self.model.nv, self.model.na) != (
            len(self.world.qpos), len(self.world.qvel), len(self.world.act)
        ):
            raise _core.ModelError(
                f"mujoco {mujoco.__version__} compiled the environment's MJCF into a model of other sizes "
                f"(nq {self.model.nq}, nv {self.model.nv}, na {self.model.na}); rendering is tested with mujoco "
                f"{', '.join(RENDER_MUJOCO_VERSIONS)}"
            )
        self.camera = mujoco.MjvCamera()
        camera = self._camera_arg
        if camera is None:
            mujoco.mjv_defaultFreeCamera(self.model, self.camera)
            self.camera.distance = self._distance_m if self._distance_m is not None else 2.5
            self.camera.elevation = self._elevation_deg
            self.camera.azimuth = self._azimuth_deg
            self._follow = True
        else:
            if isinstance(camera, int):
                cam_id = camera
            else:
                cam_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
            if cam_id < 0 or cam_id >= self.model.ncam:
                raise ValueError(f"render camera {camera!r}: the model has no such camera ({self.model.ncam} cameras)")
            self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
            self.camera.fixedcamid = cam_id
            self._follow = False

    def sync(self) -> None:
        """Copies the world's true state into the renderer's data and runs a forward pass."""
        if self.model is None:
            self._setup()
        mujoco = self._mujoco
        # The state by its parts (not mj_setState's packed layout, which differs between MuJoCo
        # releases): time, positions, velocities, activations.
        self.data.time = self.world.time
        self.data.qpos[:] = self.world.qpos
        self.data.qvel[:] = self.world.qvel
        if self.model.na:
            self.data.act[:] = self.world.act
        mujoco.mj_forward(self.model, self.data)
        if self._follow:
            self.camera.lookat[:] = self.world.centre_of_mass

    def render(self) -> npt.NDArray[Any] | None:
        self.sync()
        mujoco = self._mujoco
        if self.render_mode == "human":
            if self._viewer is None:
                import importlib

                viewer = importlib.import_module("mujoco.viewer")
                self._viewer = viewer.launch_passive(self.model, self.data)
            self._viewer.sync()
            return None
        if self._renderer is None:
            self._renderer = mujoco.Renderer(self.model, self.height, self.width)
            if self.render_mode == "depth_array":
                self._renderer.enable_depth_rendering()
            if self.quality == "fast":
                self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
                self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        r = self._renderer
        r.update_scene(self.data, camera=self.camera)
        frame: npt.NDArray[Any] = r.render()
        return frame

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None


class SimSerpentEnv(gym.Env[ObsArray, ActArray]):
    """One snake. ``SimSerpentEnv(config=None, overrides=None, render_mode=None, width=480,
    height=480, camera=None, render_quality="fast", camera_distance_m=None,
    camera_azimuth_deg=None, camera_elevation_deg=None)``: ``config`` as for
    :func:`simserpent.load_config` (a path, a dict, a :class:`simserpent.Config` or ``None``).

    Rendering: ``render_quality`` ``"fast"`` (no shadows, reflections or MSAA, as the CLI's
    ``render.quality`` default) or ``"full"`` (MuJoCo's defaults); ``camera`` ``None`` (a camera
    that follows the snake's centre of mass at ``camera_distance_m`` (m),
    ``camera_azimuth_deg`` and ``camera_elevation_deg``; by default the config's
    ``render.camera_distance_m``, ``render.camera_azimuth_deg``, ``render.camera_elevation_deg``:
    2.5 m, 90 deg, -35 deg, where the default 2 m snake spans most of the picture's width) or a
    camera of the model, by name or id.

    ``unwrapped.world`` is the :class:`simserpent.World` (true state ``qpos``, ``qvel``,
    ``time``; ``get_state()``/``set_state()`` for branching rollouts).
    """

    metadata = {"render_modes": RENDER_MODES, "render_fps": 50}

    def __init__(self, config: ConfigLike = None, overrides: Overrides = None, render_mode: str | None = None,
                 width: int = 480, height: int = 480, camera: str | int | None = None,
                 render_quality: str = "fast", camera_distance_m: float | None = None,
                 camera_azimuth_deg: float | None = None, camera_elevation_deg: float | None = None) -> None:
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode {render_mode!r} is not supported; allowed: {RENDER_MODES} or None")
        if render_mode == "human" and not has_display():
            raise ValueError(
                "render_mode='human' needs a display (DISPLAY or WAYLAND_DISPLAY is not set); "
                "use render_mode='rgb_array' (with MUJOCO_GL=egl) and gymnasium.wrappers.RecordVideo"
            )
        self.config = _config(config, overrides)
        self.core = _core.Env(self.config)
        self.world = self.core
        self.observation_space, self.action_space = _spaces(self.core)
        self.observation_names: list[str] = list(self.core.observation_names)
        self.observation_version: int = self.core.observation_version
        # Only the modes that work here (check_env renders every listed one).
        self.metadata = {
            **type(self).metadata,
            "render_modes": available_render_modes(),
            "render_fps": int(round(1.0 / self.dt)),
        }
        self.render_mode = render_mode
        if render_mode is not None:
            _mujoco_for_rendering(render_mode)
        view = _json.loads(self.config.to_json())["render"]
        self._renderer = (
            MujocoRendering(
                self.core,
                render_mode,
                width,
                height,
                camera,
                distance_m=float(view["camera_distance_m"] if camera_distance_m is None else camera_distance_m),
                quality=render_quality,
                azimuth_deg=float(view["camera_azimuth_deg"] if camera_azimuth_deg is None else camera_azimuth_deg),
                elevation_deg=float(
                    view["camera_elevation_deg"] if camera_elevation_deg is None else camera_elevation_deg
                ),
            )
            if render_mode
            else None
        )
        self._spec: EnvSpec | None = None
        self._estimation = bool(_json.loads(self.config.to_json())["estimation"]["enabled"])

    # gym.make sets the spec after construction; fill in the env's own episode length so that
    # spec.max_episode_steps says when it truncates (no TimeLimit wrapper is needed).
    @property
    def spec(self) -> EnvSpec | None:
        return self._spec

    @spec.setter
    def spec(self, value: EnvSpec | None) -> None:
        if value is not None and value.max_episode_steps is None:
            value = dataclasses.replace(value, max_episode_steps=int(self.core.max_episode_steps))
        self._spec = value

    @property
    def dt(self) -> float:
        """Time between two actions (s): ``env.control_period_secs``."""
        return float(self.core.control_period_secs)

    @property
    def max_episode_steps(self) -> int:
        return int(self.core.max_episode_steps)

    @property
    def mjcf(self) -> str:
        """The MJCF of the world (``control.method`` set from ``env.action``)."""
        return self.core.mjcf

    def _xy_info(self) -> dict[str, float]:
        x, y, _ = self.core.centre_of_mass
        x0, y0, _ = self.core.start_centre_of_mass
        return {
            "x_position": x,
            "y_position": y,
            "distance_from_origin": float(np.hypot(x - x0, y - y0)),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[ObsArray, dict[str, Any]]:
        super().reset(seed=seed)
        # The noise seed comes from the env's generator: the same seed, the same episode.
        episode_seed = int(self.np_random.integers(0, _SEED_MAX))
        obs = self.core.reset(episode_seed)
        info = {"time_secs": self.core.time_secs, "seed": episode_seed, **self._xy_info()}
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action: ActArray) -> tuple[ObsArray, float, bool, bool, dict[str, Any]]:
        a = action if isinstance(action, np.ndarray) and action.ndim == 1 else np.asarray(action).reshape(-1)
        obs, reward, terminated, truncated, info = self.core.step(a)
        # The episode's start is part of the world's state (restored by set_state).
        x0, y0, _ = self.core.start_centre_of_mass
        info["distance_from_origin"] = float(np.hypot(info["x_position"] - x0, info["y_position"] - y0))
        if self._estimation:
            info["contact_estimates"] = self.core.contact_estimates()
        if self.render_mode == "human":
            self.render()
        return obs, float(reward), bool(terminated), bool(truncated), info

    def contact_estimates(self) -> dict[str, Any]:
        """The contact estimates of the latest step (see :meth:`simserpent.World.contact_estimates`)."""
        return self.core.contact_estimates()

    def render(self) -> npt.NDArray[Any] | None:
        if self._renderer is None:
            gym.logger.warn(
                "render() called without a render_mode; make the env with render_mode='rgb_array' "
                "(or 'depth_array', 'human')"
            )
            return None
        return self._renderer.render()

    def get_state(self) -> _core.WorldState:
        """The whole state (see :meth:`simserpent.World.get_state`)."""
        return self.core.get_state()

    def set_state(self, state: _core.WorldState) -> None:
        """Back to a state from :meth:`get_state`: the same actions give the same trajectory."""
        self.core.set_state(state)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
        super().close()


def _reset_mask(options: dict[str, Any] | None, n: int) -> np.ndarray:
    mask = None if options is None else options.get("reset_mask")
    if mask is None:
        return np.ones(n, dtype=bool)
    mask = np.asarray(mask)
    if mask.shape != (n,) or mask.dtype != np.bool_:
        raise ValueError(f"options['reset_mask'] must be a bool array of shape ({n},), got {mask.dtype} {mask.shape}")
    return mask


def _seed_list(seed: int | np.integer[Any] | list[int | None] | None, n: int) -> list[int | None]:
    """Per-environment seeds as Gymnasium's SyncVectorEnv takes them: an int s gives s, s+1, ...;
    a list gives one per environment; None gives none."""
    if seed is None:
        return [None] * n
    if isinstance(seed, (int, np.integer)):
        return [int(seed) + i for i in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"reset got {len(seeds)} seeds for {n} environments")
    return [None if s is None else int(s) for s in seeds]


def _autoreset_mode(mode: AutoresetMode | str) -> AutoresetMode:
    """An AutoresetMode, or its value ("NextStep") or name ("next_step", "SAME_STEP")."""
    if isinstance(mode, str):
        by_name = {m.name.lower(): m for m in AutoresetMode}
        mode = by_name.get(mode.lower()) or next((m for m in AutoresetMode if m.value == mode), mode)
    if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        raise ValueError(
            f"autoreset_mode {mode!r} is not supported; allowed: AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP"
        )
    return mode


class SimSerpentVectorEnv(VectorEnv):
    """``num_envs`` snakes stepped together in Rust on a rayon pool of ``threads`` threads
    (0: all cores), with the GIL released.

    ``autoreset_mode``: ``AutoresetMode.NEXT_STEP`` (default: the step after an episode ends
    returns that environment's first observation of a new episode, reward 0) or
    ``AutoresetMode.SAME_STEP`` (the step that ends an episode returns the new episode's first
    observation; the last one is in ``info["final_obs"]``, its info in ``info["final_info"]``).

    Seeding is Gymnasium's SyncVectorEnv's: ``reset(seed=s)`` seeds environment i with
    ``s + i``, ``reset(seed=[...])`` one seed per environment; each environment draws the
    noise seed of every episode from its own generator exactly as :class:`SimSerpentEnv`
    does, so a vector of N equals N single environments (also in ``sync`` and ``async``
    modes). ``reset(options={"reset_mask": mask})`` resets only the masked environments.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": [], "render_fps": 50}

    def __init__(self, num_envs: int = 8, config: ConfigLike = None, overrides: Overrides = None, threads: int = 0,
                 render_mode: str | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP) -> None:
        mode = _autoreset_mode(autoreset_mode)
        for name, value, low, high in (("num_envs", num_envs, 1, 4096), ("threads", threads, 0, 256)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
                raise ValueError(
                    f"SimSerpentVectorEnv: {name} must be a whole number from {low} to {high}"
                    + (" (0: one thread per core)" if name == "threads" else "")
                    + f", got {value!r}"
                )
        if render_mode is not None:
            raise ValueError(
                f"SimSerpentVectorEnv render_mode {render_mode!r}: the Rust vector env does not render; "
                "use gym.make_vec(..., vectorization_mode='sync', render_mode='rgb_array')"
            )
        self.config = _config(config, overrides)
        rust_mode = "same_step" if mode == AutoresetMode.SAME_STEP else "next_step"
        self.core = _core.VecEnv(self.config, int(num_envs), int(threads), rust_mode)
        self.num_envs = int(num_envs)
        self._single = _core.Env(self.config)
        self.single_observation_space, self.single_action_space = _spaces(self._single)
        self.observation_names: list[str] = list(self._single.observation_names)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.dt = float(self._single.control_period_secs)
        self.metadata = {**type(self).metadata, "autoreset_mode": mode, "render_fps": int(round(1.0 / self.dt))}
        self.render_mode = render_mode
        self._np_random_seed = None
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._next_seeds = np.zeros(self.num_envs, dtype=np.uint64)

    @property
    def threads(self) -> int:
        return self.core.threads

    @property
    def max_episode_steps(self) -> int:
        return int(self.core.max_episode_steps)

    def _draw(self, i: int) -> int:
        rng = self._rngs[i]
        assert rng is not None, "reset() seeds every environment's generator first"
        return int(rng.integers(0, _SEED_MAX))

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[ObsArray, dict[str, Any]]:
        n = self.num_envs
        mask = _reset_mask(options, n)
        seeds = _seed_list(seed, n)
        if isinstance(seed, (int, np.integer)):
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(int(seed))
        episode = np.zeros(n, dtype=np.uint64)
        for i in range(n):
            if not mask[i]:
                continue
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i], _ = gym.utils.seeding.np_random(seeds[i])
            episode[i] = self._draw(i)
            self._next_seeds[i] = self._draw(i)
        obs = self.core.reset(episode.tolist(), mask.tolist())
        info: dict[str, Any] = {}
        seed_values = np.array([s if s is not None else -1 for s in seeds], dtype=np.int64)
        info["seed"] = episode.astype(np.uint64)
        info["_seed"] = mask.copy()
        info["env_seed"] = seed_values
        info["_env_seed"] = mask & (seed_values >= 0)
        return obs, info

    def step(
        self, actions: ActArray
    ) -> tuple[ObsArray, Array, npt.NDArray[np.bool_], npt.NDArray[np.bool_], dict[str, Any]]:
        a = actions if isinstance(actions, np.ndarray) and actions.ndim == 2 else np.asarray(actions).reshape(
            self.num_envs, -1
        )
        if a.dtype not in (np.float64, np.float32):
            try:
                a = a.astype(np.float64)
            except (TypeError, ValueError):
                raise TypeError(
                    f"step: actions must be real numbers, shape ({self.num_envs}, action size), "
                    f"got a numpy array of dtype {a.dtype} and shape {a.shape}"
                ) from None
        obs, rewards, terminated, truncated, terms, errors, was_reset, final_obs = self.core.step(
            a, self._next_seeds.tolist()
        )
        # Each environment that was reset draws the seed of its next episode from its generator.
        for i in np.flatnonzero(was_reset):
            self._next_seeds[i] = self._draw(int(i))
        n = self.num_envs
        stepped = ~was_reset if self.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP else np.ones(n, dtype=bool)
        infos: dict[str, Any] = {}
        for k, name in enumerate(TERM_NAMES):
            values = terms[:, k]
            infos[name] = values
            infos["_" + name] = stepped & np.isfinite(values)
        failed = np.array([e is not None for e in errors])
        if failed.any():
            infos["error"] = np.array([e or "" for e in errors], dtype=object)
            infos["_error"] = failed
        if self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP and was_reset.any():
            fo = np.empty(n, dtype=object)
            for i in np.flatnonzero(was_reset):
                fo[i] = final_obs[i].copy()
            infos["final_obs"] = fo
            infos["_final_obs"] = was_reset.copy()
            final_info = {name: infos[name].copy() for name in TERM_NAMES}
            final_info.update({"_" + name: was_reset & infos["_" + name] for name in TERM_NAMES})
            infos["final_info"] = final_info
            infos["_final_info"] = was_reset.copy()
        return obs, rewards, terminated, truncated, infos

    def close_extras(self, **kwargs: Any) -> None:
        pass


def register_envs() -> None:
    """Registers ``SimSerpent-v0`` (single and vector entry points) with Gymnasium."""
    if ENV_ID in gym.registry:
        return
    gym.register(
        id=ENV_ID,
        entry_point="simserpent.envs:SimSerpentEnv",
        vector_entry_point="simserpent.envs:SimSerpentVectorEnv",
        # The environment truncates itself at env.max_episode_secs; its spec says when
        # (SimSerpentEnv.spec fills in max_episode_steps from the config).
        max_episode_steps=None,
    )


register_envs()

"""Gymnasium environments: ``SimSerpent-v0`` and a vector environment stepped in Rust.

The observation, actions, reward and episode end are set by the config's ``[env]`` section
(see ``default_config_toml()``):

- observation (version ``env.observation_version`` = 1): measured joint angles and velocities,
  head position, quaternion (w, x, y, z) and linear velocity, optionally per link IMU
  (``env.observe_imu``) and per joint force/torque sensors (``env.observe_joint_force_torque``),
  with the ``[sensors]`` noise, seeded by ``reset(seed=...)``; ``env.observation_names`` names
  every element;
- action: joint target angles (``env.action = "position"``) or joint torques (``"torque"``),
  one per joint, held for ``env.control_period_secs``;
- reward: ``reward_forward_weight`` x forward progress - ``reward_energy_weight`` x actuator
  energy - ``reward_contact_force_weight`` x largest contact force (the terms are in ``info``);
- terminated: the simulation diverged (``info["error"]`` says why) or a contact force exceeded
  ``env.terminate_contact_force_n``; truncated: ``env.max_episode_secs`` reached.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from . import _core

ENV_ID = "SimSerpent-v0"

_SEED_MAX = 2**63 - 1


def _config(config, overrides):
    from . import load_config

    return load_config(config, overrides)


def _spaces(core) -> tuple[spaces.Box, spaces.Box]:
    n = core.observation_size
    observation_space = spaces.Box(-np.inf, np.inf, shape=(n,), dtype=np.float64)
    action_space = spaces.Box(core.action_low, core.action_high, dtype=np.float64)
    return observation_space, action_space


class SimSerpentEnv(gym.Env):
    """One snake. ``SimSerpentEnv(config=None, overrides=None)``: ``config`` as for
    :func:`simserpent.load_config` (a path, a dict, a :class:`simserpent.Config` or ``None``).
    """

    metadata = {"render_modes": []}

    def __init__(self, config=None, overrides=None, render_mode: str | None = None):
        if render_mode is not None:
            raise ValueError(
                "SimSerpentEnv has no render modes; record a run (simserpent.run with video.enabled) "
                "or open the MJCF (env.unwrapped.mjcf) in `python -m mujoco.viewer`"
            )
        self.render_mode = None
        self.config = _config(config, overrides)
        self.core = _core.Env(self.config)
        self.observation_space, self.action_space = _spaces(self.core)
        self.observation_names: list[str] = list(self.core.observation_names)
        self.observation_version: int = self.core.observation_version

    @property
    def mjcf(self) -> str:
        """The MJCF of the world (``control.method`` set from ``env.action``)."""
        return self.core.mjcf

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        # The sensor-noise seed comes from the env's generator: the same seed, the same episode.
        episode_seed = int(self.np_random.integers(0, _SEED_MAX))
        obs = self.core.reset(episode_seed)
        return obs, {"time_secs": self.core.time_secs, "seed": episode_seed}

    def step(self, action):
        a = np.ascontiguousarray(action, dtype=np.float64).reshape(-1)
        obs, reward, terminated, truncated, info = self.core.step(a)
        return obs, float(reward), bool(terminated), bool(truncated), info


class SimSerpentVectorEnv(VectorEnv):
    """``num_envs`` snakes stepped together in Rust on a rayon pool of ``threads`` threads
    (0: all cores), with the GIL released. Autoreset mode ``NEXT_STEP``: the step after an
    episode ends returns that environment's first observation of a new episode (reward 0).

    ``reset(seed=s)`` seeds environment i with ``s + i``; its k-th automatic reset gets
    ``s + i + k * num_envs``. So a vector of N equals N single :class:`SimSerpentEnv` whose
    ``core.reset`` got those seeds.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 8, config=None, overrides=None, threads: int = 0, render_mode=None):
        if render_mode is not None:
            raise ValueError("SimSerpentVectorEnv has no render modes")
        self.render_mode = None
        self.config = _config(config, overrides)
        self.core = _core.VecEnv(self.config, int(num_envs), int(threads))
        self.num_envs = int(num_envs)
        single = _core.Env(self.config)
        self.single_observation_space, self.single_action_space = _spaces(single)
        self.observation_names: list[str] = list(single.observation_names)
        del single
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._np_random_seed = None

    @property
    def threads(self) -> int:
        return self.core.threads

    def reset(self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None):
        if isinstance(seed, (list, tuple)):
            seed = seed[0]
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed)
        first = int(self.np_random.integers(0, _SEED_MAX)) if seed is None else int(seed)
        obs = self.core.reset(first)
        return obs, {"seed": np.arange(self.num_envs, dtype=np.int64) + first}

    def step(self, actions):
        a = np.ascontiguousarray(actions, dtype=np.float64).reshape(self.num_envs, -1)
        obs, rewards, terminated, truncated, terms, errors = self.core.step(a)
        mask = np.ones(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {
            "forward_progress_m": terms[:, 0],
            "_forward_progress_m": mask,
            "energy_j": terms[:, 1],
            "_energy_j": mask,
            "peak_contact_force_n": terms[:, 2],
            "_peak_contact_force_n": mask,
        }
        failed = np.array([e is not None for e in errors])
        if failed.any():
            infos["error"] = np.array([e or "" for e in errors], dtype=object)
            infos["_error"] = failed
        return obs, rewards, terminated, truncated, infos


def register_envs() -> None:
    """Registers ``SimSerpent-v0`` (single and vector entry points) with Gymnasium."""
    if ENV_ID in gym.registry:
        return
    gym.register(
        id=ENV_ID,
        entry_point="simserpent.envs:SimSerpentEnv",
        vector_entry_point="simserpent.envs:SimSerpentVectorEnv",
        # The environment truncates itself at env.max_episode_secs.
        max_episode_steps=None,
    )


register_envs()

"""A thin stable-baselines3 ``VecEnv`` over the Rust vector environment.

``SB3VecEnv(num_envs=8, config=None, overrides=None, threads=0)`` steps every snake in Rust
(GIL released, ``threads`` threads) and speaks SB3's protocol: ``reset() -> obs``,
``step_async``/``step_wait -> (obs, rewards, dones, infos)`` with automatic reset in the same
step, ``infos[i]["terminal_observation"]`` and ``infos[i]["TimeLimit.truncated"]`` as SB3's
``DummyVecEnv`` gives them; ``seed(s)`` seeds the next ``reset()`` (environment i: ``s + i``).

It subclasses ``stable_baselines3.common.vec_env.VecEnv`` when stable-baselines3 is installed
(it is not a dependency of this package), else a stand-in with the same methods, so it can be
tested without torch::

    from stable_baselines3 import PPO
    from simserpent.sb3 import SB3VecEnv
    model = PPO("MlpPolicy", SB3VecEnv(num_envs=8), verbose=1).learn(200_000)
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any, Union

import numpy as np
import numpy.typing as npt
from gymnasium.vector import AutoresetMode

from .envs import TERM_NAMES, SimSerpentVectorEnv

if TYPE_CHECKING:
    from . import ConfigLike, Overrides

#: Which environments: all (None), one, or several.
Indices = Union[None, int, Iterable[int]]

try:  # pragma: no cover - depends on what is installed
    from stable_baselines3.common.vec_env import VecEnv as _Base

    HAVE_SB3 = True
except ImportError:
    HAVE_SB3 = False

    class _Base:  # the part of SB3's VecEnv this adapter relies on
        def __init__(self, num_envs, observation_space, action_space):
            self.num_envs = num_envs
            self.observation_space = observation_space
            self.action_space = action_space
            self.reset_infos = [{} for _ in range(num_envs)]
            self._seeds = [None for _ in range(num_envs)]
            self._options = [{} for _ in range(num_envs)]
            self.render_mode = None

        def step(self, actions):
            self.step_async(actions)
            return self.step_wait()

        def seed(self, seed=None):
            if seed is None:
                seed = int(np.random.randint(0, 2**31 - 1))
            self._seeds = [seed + idx for idx in range(self.num_envs)]
            return self._seeds

        def set_options(self, options=None):
            self._options = [options or {}] * self.num_envs if not isinstance(options, list) else options

        def _reset_seeds(self):
            self._seeds = [None for _ in range(self.num_envs)]

        def _reset_options(self):
            self._options = [{} for _ in range(self.num_envs)]

        @property
        def unwrapped(self):
            return self


class SB3VecEnv(_Base):
    """SB3's ``VecEnv`` protocol over :class:`simserpent.envs.SimSerpentVectorEnv` (same-step
    autoreset)."""

    def __init__(
        self, num_envs: int = 8, config: ConfigLike = None, overrides: Overrides = None, threads: int = 0
    ) -> None:
        self.venv = SimSerpentVectorEnv(
            num_envs=num_envs, config=config, overrides=overrides, threads=threads,
            autoreset_mode=AutoresetMode.SAME_STEP,
        )
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._actions: np.ndarray | None = None
        self.metadata = {"render_modes": [], "render_fps": self.venv.metadata["render_fps"]}

    def reset(self) -> npt.NDArray[np.float64]:
        seeds = list(self._seeds)
        seed = None if all(s is None for s in seeds) else seeds
        obs, info = self.venv.reset(seed=seed)
        self.reset_infos = [{"seed": int(info["seed"][i])} for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs  # float64, as the observation space

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions).reshape(self.num_envs, -1)

    def step_wait(
        self,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float32], npt.NDArray[np.bool_], list[dict[str, Any]]]:
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        dones = terminated | truncated
        out: list[dict[str, Any]] = []
        for i in range(self.num_envs):
            d: dict[str, Any] = {n: float(infos[n][i]) for n in TERM_NAMES if infos["_" + n][i]}
            if "error" in infos and infos["_error"][i]:
                d["error"] = infos["error"][i]
            d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            if dones[i]:
                d["terminal_observation"] = infos["final_obs"][i]
            out.append(d)
        return obs, rewards.astype(np.float32), dones, out

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices: Indices = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Indices = None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Indices = None, **method_kwargs: Any) -> list[Any]:
        method = getattr(self.venv, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: Indices = None) -> list[bool]:
        return [False for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]

    def render(self, mode: str | None = None) -> None:
        return None

    def _indices(self, indices: Indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)

"""The installed wheel beside another `mujoco` release, in one process (run by scripts/check-wheel).

Usage: python smoke.py MUJOCO_VERSION   (the `mujoco` version installed beside the wheel)
"""

from __future__ import annotations

import os
import sys
import time

# Run with no display and no MUJOCO_GL (scripts/check-wheel unsets them), as on a server:
# importing simserpent chooses MuJoCo's offscreen back-end (EGL) before `mujoco` is imported.
assert "MUJOCO_GL" not in os.environ, "scripts/check-wheel runs this without MUJOCO_GL"

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

import simserpent

assert os.environ.get("MUJOCO_GL") == "egl", os.environ.get("MUJOCO_GL")
import mujoco  # noqa: E402  (after simserpent, as a user's script that never names it would)


def loaded_libmujoco() -> list[str]:
    """The libmujoco files mapped into this process."""
    with open("/proc/self/maps") as f:
        paths = {line.split()[-1] for line in f if "libmujoco" in line}
    return sorted(paths)


def main() -> None:
    expected = sys.argv[1]
    assert mujoco.__version__ == expected, (mujoco.__version__, expected)
    assert simserpent.mujoco_version() == "3.17.0", simserpent.mujoco_version()
    print(f"mujoco {mujoco.__version__} (Python package) and simserpent {simserpent.__version__} (MuJoCo "
          f"{simserpent.mujoco_version()}) imported in one process")

    # The `mujoco` package steps its own model.
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    assert data.qpos[2] < 0.0, data.qpos  # it falls

    # A SimSerpent episode (fast preset: the check stays short).
    env = gym.make("SimSerpent-v0", overrides={"env.preset": "fast"})
    obs, info = env.reset(seed=1)
    start = time.perf_counter()
    steps, total = 0, 0.0
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        total += float(reward)
        steps += 1
        if terminated or truncated:
            break
    assert np.all(np.isfinite(obs)) and "error" not in info, info
    print(f"SimSerpent-v0: {steps} steps in {time.perf_counter() - start:.2f} s, return {total:.3f}, "
          f"x {info['x_position']:.3f} m")

    libs = loaded_libmujoco()
    print("libmujoco mapped:", *libs, sep="\n  ")
    own = [p for p in libs if os.sep + "simserpent.libs" + os.sep in p]
    other = [p for p in libs if p not in own]
    assert len(own) == 1 and len(other) >= 1, libs

    # Gymnasium's checker with its defaults, headless (renders every listed mode).
    check_env(gym.make("SimSerpent-v0", overrides={"env.preset": "fast"}).unwrapped)
    render_env = gym.make("SimSerpent-v0", overrides={"env.preset": "fast"}, render_mode="rgb_array",
                          width=160, height=120)
    render_env.reset(seed=0)
    frame = render_env.render()
    assert frame is not None and frame.shape == (120, 160, 3) and frame.std() > 0, None if frame is None else frame.shape
    print(f"check_env passed; rgb_array frame {frame.shape} drawn by mujoco {mujoco.__version__} "
          f"(MUJOCO_GL unset at start, {os.environ['MUJOCO_GL']} chosen by simserpent)")
    print("OK")


if __name__ == "__main__":
    main()

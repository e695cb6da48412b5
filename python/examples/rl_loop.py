"""A short reinforcement-learning loop on `SimSerpent-v0`: a scripted travelling-wave policy
against a random policy, on 4 snakes at once in the vector environment.

    python python/examples/rl_loop.py
"""

import gymnasium as gym
import numpy as np
import numpy.typing as npt

import simserpent  # noqa: F401  (registers SimSerpent-v0)

OVERRIDES = {
    "snake.n_links": 8,
    "terrain.kind": "none",
    "env.max_episode_secs": 4.0,
    "env.reward_energy_weight": 0.01,
    "sensors.noise_enabled": True,
    "sensors.joint_angle.std": 0.002,
}


def scripted(t: float, n_joints: int) -> npt.NDArray[np.float32]:
    """Lateral undulation: a sine wave travelling from head to tail, as a normalised action
    (1 = snake.joint_range_deg, 90 deg by default: amplitude 0.35 is about 0.55 rad)."""
    return np.asarray(0.35 * np.sin(2 * np.pi * 1.0 * t - 0.8 * np.arange(n_joints)), dtype=np.float32)


# One environment, the Gymnasium way.
env = gym.make("SimSerpent-v0", overrides=OVERRIDES)
n_actions = int(np.prod(env.action_space.shape or (0,)))
for name in ("random", "scripted"):
    obs, info = env.reset(seed=42)
    total, t, done = 0.0, 0.0, False
    while not done:
        a = env.action_space.sample() if name == "random" else scripted(t, n_actions)
        obs, reward, terminated, truncated, info = env.step(a)
        total += float(reward)
        t = info["time_secs"]
        done = terminated or truncated
    print(f"{name:>8s} policy: return {total:+.4f} over {t:.2f} s")
env.close()

# Four snakes stepped together in Rust (GIL released, all cores).
vec = gym.make_vec("SimSerpent-v0", num_envs=4, vectorization_mode="vector_entry_point", overrides=OVERRIDES)
obs, info = vec.reset(seed=0)
returns = np.zeros(4)
n_joints = int(np.prod(vec.single_action_space.shape or (0,)))
for k in range(200):  # 4 s per episode at 0.02 s per action
    t = k * 0.02
    actions = np.stack([scripted(t, n_joints) * (0.5 + 0.25 * i) for i in range(4)])
    obs, rewards, terminated, truncated, infos = vec.step(actions)
    returns += rewards
print("vector env, amplitude 0.175/0.26/0.35/0.44 (normalised): returns", np.round(returns, 4))
vec.close()

"""PPO (stable-baselines3) on SimSerpent-v0 through SB3's default entry points, then a video.

Not run by the tests (torch is large). Needs::

    pip install stable-baselines3 moviepy        # torch comes with stable-baselines3
    python python/examples/sb3_ppo.py [--steps 200000] [--envs 4] [--fast]

(Headless works as it is: without a display ``import simserpent`` chooses MuJoCo's EGL back-end.)
The settings that learn in a budget of a few hundred thousand steps, and the reference learning
curve, are in ``ppo_learning_curve.py`` and the guide's Gymnasium page.

1. ``make_vec_env("SimSerpent-v0", n_envs=...)`` -- SB3's own vectorisation (it makes each env
   with ``render_mode="rgb_array"``, wraps it in ``Monitor`` and a ``DummyVecEnv``); with
   ``--rust-vec`` instead ``simserpent.sb3.SB3VecEnv`` (all snakes stepped in Rust, GIL released);
2. ``PPO("MlpPolicy", env)`` learns a travelling wave (the reward is the forward velocity of
   the centre of mass minus a small control cost, Swimmer-v5's convention);
3. ``gymnasium.wrappers.RecordVideo`` saves an episode of the trained policy to ``videos/``.

With ``--fast`` the envs use ``[env] preset = "fast"`` (about 8x more env steps/s, see
BENCHMARKS.md). Swimmer-like tasks want a discount close to 1 (``gamma=0.9999``), as in the
RL Zoo's Swimmer settings.
"""

from __future__ import annotations

import argparse

import gymnasium as gym

import simserpent  # noqa: F401  (registers SimSerpent-v0; EGL without a display)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--envs", type=int, default=4)
    ap.add_argument("--fast", action="store_true", help='[env] preset = "fast"')
    ap.add_argument("--rust-vec", action="store_true", help="simserpent.sb3.SB3VecEnv instead of make_vec_env")
    ap.add_argument("--video-dir", default="videos")
    a = ap.parse_args()

    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    overrides = {"env.preset": "fast"} if a.fast else {}
    if a.rust_vec:
        from simserpent.sb3 import SB3VecEnv

        venv = SB3VecEnv(num_envs=a.envs, overrides=overrides)
    else:
        venv = make_vec_env("SimSerpent-v0", n_envs=a.envs, env_kwargs={"overrides": overrides})
    model = PPO("MlpPolicy", venv, gamma=0.9999, verbose=1, seed=0)
    model.learn(total_timesteps=a.steps)
    model.save("ppo_simserpent")

    # A video of one episode of the trained policy.
    env = gym.make("SimSerpent-v0", render_mode="rgb_array", overrides=overrides)
    with gym.wrappers.RecordVideo(env, a.video_dir, episode_trigger=lambda e: True, name_prefix="ppo") as video:
        obs, _ = video.reset(seed=123)
        done, total = False, 0.0
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, info = video.step(action)
            total += float(reward)
            done = terminated or truncated
    print(f"return {total:.3f}, distance {info['distance_from_origin']:.3f} m; video in {a.video_dir}/")


if __name__ == "__main__":
    main()

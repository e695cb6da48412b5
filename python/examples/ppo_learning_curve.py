"""The reference learning curve of SimSerpent-v0: PPO (stable-baselines3) on the default task
with the fast preset, evaluated as it learns, beside the returns of three fixed policies.

Needs ``pip install stable-baselines3 matplotlib`` (stable-baselines3 brings torch). Run::

    python python/examples/ppo_learning_curve.py --steps 300000 --out ppo-curve

It writes ``<out>/curve.csv`` (environment steps, wall seconds, mean and per-seed evaluation
returns), ``<out>/references.csv`` (the fixed policies) and ``<out>/learning_curve.png``, and
prints one line per evaluation. The settings are the ones the guide documents (and why):

- ``VecNormalize`` of observations and rewards: joint velocities (rad/s) are two orders of
  magnitude larger than the head height (m), and a forward velocity of a few cm/s gives per-step
  rewards of ~0.01, which the value function fits poorly unscaled;
- ``log_std_init=-1`` (action noise 0.37 of the [-1, 1] range instead of 1): with std 1 most
  sampled actions saturate at +-90 deg joint targets, which the servos cannot follow, and the
  snake thrashes in place;
- ``n_steps=256`` per environment (8 environments: 2,048 steps per update), so a budget of a
  few hundred thousand steps makes ~150 updates (SB3's default 2,048 per environment makes
  one update per 16,384 steps: 25,000 steps are 1-2 updates, which cannot show learning);
- ``gamma=0.99`` (a 2-s horizon at 20 ms per action covers one gait cycle).

Evaluation: the deterministic policy (mean action) on ``--eval-seeds`` fixed seeds, one whole
episode (10 s) each, with the observation normalisation frozen; the return is the sum of the
per-action rewards (forward velocity in m/s, so a return R over 500 actions of 20 ms is a mean
speed of R / 500 m/s).
"""

from __future__ import annotations

import argparse
import csv
import os
import time
from pathlib import Path
from collections.abc import Callable
from typing import Any

import numpy as np

import simserpent
from simserpent.sb3 import SB3VecEnv

FAST = {"env.preset": "fast"}


def episode_returns(policy: Callable[[np.ndarray, float], np.ndarray], seeds: list[int]) -> list[float]:
    """One whole episode per seed with ``policy(obs, t_secs) -> action``; the returns."""
    import gymnasium as gym

    out = []
    for seed in seeds:
        env = gym.make("SimSerpent-v0", overrides=FAST)
        obs, info = env.reset(seed=seed)
        total, done, t = 0.0, False, 0.0
        while not done:
            obs, reward, terminated, truncated, info = env.step(policy(obs, t))
            total += float(reward)
            t += float(env.get_wrapper_attr("dt"))
            done = terminated or truncated
        out.append(total)
        env.close()
    return out


def references(seeds: list[int]) -> dict[str, list[float]]:
    """Returns of fixed policies: zero action (joints held straight), uniform random actions,
    and the config's built-in gait as actions (simserpent.Gait)."""
    rng = np.random.default_rng(0)
    gait = simserpent.Gait(overrides=FAST)
    n = gait.n_joints
    return {
        "zero action": episode_returns(lambda o, t: np.zeros(n, dtype=np.float32), seeds),
        "random actions": episode_returns(lambda o, t: rng.uniform(-1, 1, n).astype(np.float32), seeds),
        "built-in gait": episode_returns(lambda o, t: gait.action(t), seeds),
    }


def evaluate(model: Any, train_env: Any, seeds: list[int]) -> list[float]:
    """The deterministic policy's return per seed (observations normalised with the training
    statistics, frozen)."""

    def act(obs: np.ndarray, t: float) -> np.ndarray:
        action, _ = model.predict(train_env.normalize_obs(obs[None, :]), deterministic=True)
        return np.asarray(action[0], dtype=np.float32)

    return episode_returns(act, seeds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=300_000, help="environment steps to train")
    ap.add_argument("--envs", type=int, default=8)
    ap.add_argument("--eval-every", type=int, default=20_480, help="environment steps between evaluations")
    ap.add_argument("--eval-seeds", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1, help="torch and Rust threads")
    ap.add_argument("--gamma", type=float, default=0.99, help="discount (also of VecNormalize's returns)")
    ap.add_argument("--out", default="ppo-curve")
    ap.add_argument("--max-wall-secs", type=float, default=0.0,
                    help="stop training after this many seconds of wall time (0: no limit)")
    ap.add_argument("--plot-only", action="store_true", help="plot <out>/curve.csv and references.csv again")
    a = ap.parse_args()
    if a.plot_only:
        replot(Path(a.out))
        return

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    torch.set_num_threads(a.threads)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = [1000 + k for k in range(a.eval_seeds)]

    refs = references(seeds)
    with open(out / "references.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["policy", "mean_return", *[f"seed_{s}" for s in seeds]])
        for name, r in refs.items():
            w.writerow([name, f"{np.mean(r):.4f}", *[f"{x:.4f}" for x in r]])
            print(f"reference {name}: mean return {np.mean(r):.3f} ({', '.join(f'{x:.3f}' for x in r)})")

    venv = VecNormalize(VecMonitor(SB3VecEnv(num_envs=a.envs, overrides=FAST, threads=a.threads)), gamma=a.gamma)
    venv.seed(a.seed)
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=256,
        batch_size=256,
        n_epochs=10,
        gamma=a.gamma,
        gae_lambda=0.95,
        learning_rate=3e-4,
        policy_kwargs={"log_std_init": -1.0, "net_arch": [64, 64]},
        seed=a.seed,
        verbose=0,
        device="cpu",
    )
    rows: list[list[Any]] = []
    started = time.perf_counter()

    def record(steps: int) -> None:
        r = evaluate(model, venv, seeds)
        wall = time.perf_counter() - started
        rows.append([steps, round(wall, 1), float(np.mean(r)), *r])
        print(f"steps {steps:>8}  wall {wall:7.0f} s  eval return {np.mean(r):7.3f}  ({', '.join(f'{x:.3f}' for x in r)})",
              flush=True)
        with open(out / "curve.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["env_steps", "wall_secs", "mean_return", *[f"seed_{s}" for s in seeds]])
            w.writerows(rows)

    class Every(BaseCallback):  # type: ignore[misc,unused-ignore]
        def __init__(self) -> None:
            super().__init__()
            self.next = a.eval_every

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next:
                self.next += a.eval_every
                record(self.num_timesteps)
            return not (a.max_wall_secs > 0 and time.perf_counter() - started > a.max_wall_secs)

    record(0)
    model.learn(total_timesteps=a.steps, callback=Every())
    if not rows or rows[-1][0] < model.num_timesteps:
        record(model.num_timesteps)
    model.save(out / "ppo_simserpent")
    venv.save(str(out / "vecnormalize.pkl"))
    plot(out, rows, refs)


def replot(out: Path) -> None:
    """The figure again from the tables a (possibly interrupted) run wrote."""
    with open(out / "curve.csv", newline="") as f:
        rows: list[list[Any]] = [[float(x) for x in r] for r in list(csv.reader(f))[1:]]
    with open(out / "references.csv", newline="") as f:
        refs = {r[0]: [float(x) for x in r[2:]] for r in list(csv.reader(f))[1:]}
    plot(out, rows, refs)


def plot(out: Path, rows: list[list[Any]], refs: dict[str, list[float]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = np.array([r[0] for r in rows]) / 1000.0
    per_seed = np.array([r[3:] for r in rows])
    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=120)
    ax.plot(steps, per_seed.mean(axis=1), color="C0", lw=2, label="PPO (deterministic), mean")
    ax.fill_between(steps, per_seed.min(axis=1), per_seed.max(axis=1), color="C0", alpha=0.2,
                    label="PPO, min-max over evaluation seeds")
    top = max(1.0, float(per_seed.max()))
    for (name, r), color in zip(refs.items(), ("C7", "C3", "C2")):
        level = float(np.mean(r))
        if level > 3.0 * top:  # far above the curve: named, not drawn (the curve would flatten)
            ax.plot([], [], " ", label=f"{name}: {level:.0f} (off the scale)")
        else:
            ax.axhline(level, color=color, ls="--", lw=1, label=f"{name}: {level:.1f}")
    ax.set_xlabel("environment steps (thousands; 20 ms each)")
    ax.set_ylabel("episode return (10 s)")
    ax.set_title("SimSerpent-v0, fast preset: PPO learning curve")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(out / "learning_curve.png")
    print(f"wrote {out / 'learning_curve.png'}")


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()

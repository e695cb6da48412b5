"""Environment steps per second: SimSerpent's Gymnasium env (Rust) against a pure-Python env on
the official `mujoco` bindings, on the same MJCF, with the same observation, noise model,
reward, clipping, divergence checks and control period.

    python python/bench/bench_env.py [--seconds 3] [--control-period 0.02] [--json out.json]

(a) `SimSerpentEnv` (one env through the Gymnasium wrapper) and `simserpent.World` (the core,
    no wrapper);
(b) `SimSerpentVectorEnv` of 8 on 1 and on 2 threads (env steps per second = 8 x vector steps);
(c) `PyMujocoEnv` below: numpy + `mujoco.mj_step`, one env.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import mujoco
import numpy as np

import simserpent
from simserpent.envs import SimSerpentEnv, SimSerpentVectorEnv


class PyMujocoEnv:
    """The same environment written in Python on the official bindings, honestly: numpy for the
    observation, noise and reward; one `mj_step` call per physics step."""

    def __init__(self, cfg: dict, mjcf: str, n_links: int):
        e = cfg["env"]
        self.m = mujoco.MjModel.from_xml_string(mjcf)
        self.d = mujoco.MjData(self.m)
        m = self.m
        nj = n_links - 1
        jid = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"joint_{j + 1:02d}") for j in range(nj)]
        self.qadr = np.array([m.jnt_qposadr[i] for i in jid])
        self.dadr = np.array([m.jnt_dofadr[i] for i in jid])
        kind = e["action"]
        self.act = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{kind}_{j + 1:02d}") for j in range(nj)])
        self.bodies = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"link_{i:02d}") for i in range(n_links)])
        self.head = int(self.bodies[0])
        self.mass = m.body_mass[self.bodies]
        self.key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "initial")
        if kind == "position":
            r = np.deg2rad(cfg["snake"]["joint_range_deg"])
            self.lo, self.hi = np.full(nj, -r), np.full(nj, r)
            self.scale = 1.0
        else:
            self.lo, self.hi = np.full(nj, cfg["snake"]["torque_range_nm"][0]), np.full(nj, cfg["snake"]["torque_range_nm"][1])
            self.scale = 1.0 / cfg["control"]["torque_gear"]
        self.substeps = int(round(e["control_period_secs"] / cfg["general"]["timestep_secs"]))
        self.max_steps = int(e["max_episode_secs"] / e["control_period_secs"] + 1e-9)
        self.w = (e["reward_forward_weight"], e["reward_energy_weight"], e["reward_contact_force_weight"])
        s = cfg["sensors"]
        self.noise = s["noise_enabled"]
        self.std_q = s["joint_angle"]["std"]
        self.std_v = s["joint_velocity"]["std"]
        self.guard_every = cfg["safety"]["check_every_n_steps"]
        self.guard_limit = cfg["safety"]["max_kinetic_energy_j_per_kg"] * self.mass.sum()
        self.vel6 = np.zeros(6)
        self.force6 = np.zeros(6)

    def _com(self):
        return (self.mass[:, None] * self.d.xipos[self.bodies]).sum(axis=0) / self.mass.sum()

    def _obs(self):
        d = self.d
        q = d.qpos[self.qadr]
        v = d.qvel[self.dadr]
        if self.noise:
            q = q + self.rng.normal(0.0, self.std_q, q.shape)
            v = v + self.rng.normal(0.0, self.std_v, v.shape)
        mujoco.mj_objectVelocity(self.m, d, mujoco.mjtObj.mjOBJ_BODY, self.head, self.vel6, 0)
        return np.concatenate([q, v, d.xpos[self.head], d.xquat[self.head], self.vel6[3:]])

    def reset(self, seed: int):
        mujoco.mj_resetDataKeyframe(self.m, self.d, self.key)
        self.d.ctrl[:] = 0.0
        mujoco.mj_forward(self.m, self.d)
        self.rng = np.random.default_rng(seed)
        self.steps = 0
        self.com = self._com()
        w, x, y, z = self.d.xquat[self.head]
        h = np.array([1 - 2 * (y * y + z * z), 2 * (x * y + w * z)])
        self.heading = h / np.linalg.norm(h)
        return self._obs()

    def step(self, action):
        m, d = self.m, self.d
        d.ctrl[self.act] = np.clip(action, self.lo, self.hi) * self.scale
        dt = m.opt.timestep
        energy = 0.0
        error = None
        for k in range(self.substeps):
            mujoco.mj_step(m, d)
            if not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
                error = "diverged"
                break
            if (k + 1) % self.guard_every == 0:
                mujoco.mj_energyVel(m, d)
                if d.energy[1] > self.guard_limit:
                    error = "runaway energy"
                    break
            energy += np.abs(d.qfrc_actuator[self.dadr] * d.qvel[self.dadr]).sum() * dt
        self.steps += 1
        com = self._com()
        progress = float((com[:2] - self.com[:2]) @ self.heading)
        self.com = com
        # The peak contact force is always computed (SimSerpent's info always has it).
        peak = 0.0
        for c in range(d.ncon):
            mujoco.mj_contactForce(m, d, c, self.force6)
            peak = max(peak, abs(self.force6[0]))
        period = self.substeps * dt
        # Rates, as SimSerpent's [env] reward: forward velocity, mean power.
        reward = self.w[0] * progress / period - self.w[1] * energy / period - self.w[2] * peak
        terminated = error is not None
        truncated = not terminated and self.steps >= self.max_steps
        return self._obs(), reward, terminated, truncated, {"energy_j": energy}


#: CPU use (process CPU time / wall time, %) of the latest `timed` call.
LAST_CPU_PERCENT = [0.0]


def timed(step, reset, seconds: float) -> tuple[float, int]:
    reset()
    n = 0
    t0 = time.perf_counter()
    c0 = time.process_time()
    while True:
        for _ in range(50):
            if step():
                reset()
            n += 1
        dt = time.perf_counter() - t0
        if dt >= seconds:
            LAST_CPU_PERCENT[0] = 100.0 * (time.process_time() - c0) / dt
            return n / dt, n


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=3.0, help="wall time per measurement")
    ap.add_argument("--control-period", type=float, default=0.02, help="env.control_period_secs")
    ap.add_argument("--links", type=int, default=10)
    ap.add_argument("--integrator", default="RK4", help="general.integrator (RK4, implicitfast, Euler)")
    ap.add_argument("--repeats", type=int, default=3, help="take the best of this many measurements")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--vector-only", action="store_true", help="only the vector env (1 and 2 threads)")
    a = ap.parse_args()
    overrides = {
        "snake.n_links": a.links,
        "general.integrator": a.integrator,
        "env.control_period_secs": a.control_period,
        "env.max_episode_secs": 1000.0,
        "env.reward_energy_weight": 0.01,
        "sensors.noise_enabled": True,
        "sensors.joint_angle.std": 0.001,
        "sensors.joint_velocity.std": 0.01,
        # The layout and action units of PyMujocoEnv (the conventions of the RL environments): x/y observed,
        # physical actions, no reset noise, no control cost.
        "env.exclude_current_positions_from_observation": False,
        "env.normalize_action": False,
        "env.reset_noise_scale": 0.0,
        "env.reset_heading_noise_rad": 0.0,
        "env.reward_ctrl_cost_weight": 0.0,
    }
    cfg = simserpent.load_config(overrides=overrides)
    cfg_dict = json.loads(cfg.to_json())
    nj = a.links - 1
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.5, 0.5, size=(4096, nj))
    results = {}
    variants: list[tuple[str, object]] = []

    def best(name, fn):
        # Measured later, round-robin over all variants, so that load from other processes
        # on a shared machine hits every variant alike; the best of `repeats` rounds is kept.
        variants.append((name, fn))

    # Same environment? Without noise, both must give the same observations and rewards.
    exact = cfg.with_overrides(["sensors.noise_enabled=false"])
    w_exact = simserpent.World(exact)
    p_exact = PyMujocoEnv(json.loads(exact.to_json()), exact.env_mjcf(), a.links)
    diffs = [np.abs(w_exact.reset(0) - p_exact.reset(0)).max()]
    reward_diffs = []
    for i in range(100):
        o1, r1, *_ = w_exact.step(actions[i])
        o2, r2, *_ = p_exact.step(actions[i])
        diffs.append(np.abs(o1 - o2).max())
        reward_diffs.append(abs(r1 - r2))
    results["check_max_obs_diff"] = float(max(diffs))
    results["check_max_reward_diff"] = float(max(reward_diffs))
    print(f"check (noise off, 100 steps): max |obs diff| {max(diffs):.3g}, max |reward diff| {max(reward_diffs):.3g}")

    env = SimSerpentEnv(cfg)
    k = [0]

    def gym_step():
        k[0] += 1
        _, _, te, tr, _ = env.step(actions[k[0] % 4096])
        return te or tr

    best("SimSerpentEnv (gymnasium, 1 env)", lambda: timed(gym_step, lambda: env.reset(seed=0), a.seconds))

    world = simserpent.World(cfg)

    def world_step():
        k[0] += 1
        return world.step(actions[k[0] % 4096])[2]

    best("simserpent.World (core, 1 env)", lambda: timed(world_step, lambda: world.reset(0), a.seconds))

    py = PyMujocoEnv(cfg_dict, cfg.env_mjcf(), a.links)

    def py_step():
        k[0] += 1
        _, _, te, tr, _ = py.step(actions[k[0] % 4096])
        return te or tr

    best("pure Python + mujoco bindings (1 env)", lambda: timed(py_step, lambda: py.reset(0), a.seconds))

    # The same random action stream as the single envs (physics cost depends on the actions).
    batches = actions.reshape(512, 8, nj)
    for threads in (1, 2):
        vec = SimSerpentVectorEnv(num_envs=8, config=cfg, threads=threads)

        def rate(vec=vec):
            def vec_step():
                k[0] += 1
                vec.step(batches[k[0] % 512])
                return False

            r, n = timed(vec_step, lambda: vec.reset(seed=0), a.seconds)
            return 8 * r, 8 * n

        best(f"SimSerpentVectorEnv 8 envs, {threads} thread(s)", rate)

    if a.vector_only:
        variants[:] = [v for v in variants if v[0].startswith("SimSerpentVectorEnv")]
    cpu: dict[str, float] = {}
    for _ in range(a.repeats):
        for name, fn in variants:
            rate = fn()[0]
            if rate > results.get(name, 0.0):
                results[name] = rate
                cpu[name] = LAST_CPU_PERCENT[0]
    for name, _ in variants:
        per_cpu = results[name] / max(cpu[name] / 100.0, 1e-9)
        print(
            f"{name:<45s} {results[name]:10.1f} env steps/s   (CPU {cpu[name]:5.0f} %, {per_cpu:8.1f} per CPU-second)",
            flush=True,
        )
    results["cpu_percent"] = cpu

    if not a.vector_only:
        results["speedup_gym_vs_python"] = (
            results["SimSerpentEnv (gymnasium, 1 env)"] / results["pure Python + mujoco bindings (1 env)"]
        )
        print(f"speed-up of SimSerpentEnv over the pure-Python env: {results['speedup_gym_vs_python']:.2f}x")
    results["vector_scaling_2_vs_1_thread"] = (
        results["SimSerpentVectorEnv 8 envs, 2 thread(s)"] / results["SimSerpentVectorEnv 8 envs, 1 thread(s)"]
    )
    results["setup"] = {
        "links": a.links,
        "control_period_secs": a.control_period,
        "timestep_secs": cfg_dict["general"]["timestep_secs"],
        "integrator": cfg_dict["general"]["integrator"],
        "terrain": cfg_dict["terrain"]["kind"],
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "mujoco": mujoco.__version__,
    }
    print(f"vector env scaling, 2 threads vs 1: {results['vector_scaling_2_vs_1_thread']:.2f}x")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()

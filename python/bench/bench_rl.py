"""RL throughput and the accuracy of the physics presets.

    python python/bench/bench_rl.py throughput [--seconds 3] [--repeats 3] [--json out.json]
        [--set key=value ...] [--with key=value ...] [--only substring ...]
    python python/bench/bench_rl.py accuracy [--secs 10] [--episodes 16] [--first-seed 0]
        [--floors stick_slip] [--candidates fast,implicitfast@2,implicitfast@4:8,...] [--json out.json]
        [--set key=value ...]

``--set key=value`` (repeatable, the CLI's config overrides: a TOML value, e.g.
``--set estimation.enabled=true --set sensors.noise_enabled=true``) applies to every SimSerpent
variant. ``--with key=value`` (throughput; repeatable) measures every SimSerpent variant a second
time with these overrides added, interleaved with the first in the same rounds, so the ratio
is not skewed by a machine whose load changes (``--with estimation.enabled=true``: the cost of
the contact estimator in the loop). ``--only`` keeps the variants whose name contains one of
the given substrings (e.g. ``--only SimSerpent-v0``).

throughput: env steps per second (wall, and per CPU-second of this process) of
  - ``gym.make("SimSerpent-v0")`` (the 10-link default snake and terrain, random actions in
    [-1, 1]) with the default physics and with ``env.preset = "fast"``;
  - the Rust vector env (``SimSerpentVectorEnv``, 8 envs) on 1 and 2 threads (default and fast);
  - Gymnasium's ``Swimmer-v5`` (``gymnasium[mujoco]`` on the same ``mujoco`` wheel).
  Variants are measured round-robin, best of ``--repeats`` (the machine may be shared); the
  output ends with a markdown table (with date, CPU and load average) for BENCHMARKS.md.

accuracy: a reference gait (the config's sine wave, 30 deg, 0.5 Hz, 40 deg lag; through the
  environment as normalised actions, ``simserpent.Gait.action``) for ``--secs`` seconds from
  ``--episodes`` starts (the default reset noise, seeds ``--first-seed``, +1, ...) with the
  default physics and with each candidate physics (``integrator@timestep_ms``, e.g.
  ``implicitfast@2``; ``fast`` = the preset; ``perturbed`` = the default physics with 1e-6 rad
  reset noise, a single start's sensitivity; any of them with ``:contact_ms`` fixes
  ``physics.environment_contact_time_constant_secs``, e.g. ``default:8`` = the default physics
  with 8 ms link-obstacle/ground contacts): means over the starts (with standard errors) of the speed of travel (m/s), the
  heading of travel (rad) and the mean per-action peak contact force (N), and env steps/s of the
  vector env (all cores); the differences to the default physics. Why an ensemble: the
  undulating snake is chaotic -- a 1e-6 rad change of the start moves one 20 s trajectory's
  speed by ~5 % and its heading by ~0.15 rad -- so single trajectories cannot be compared.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
import tomllib

import gymnasium as gym
import numpy as np

import simserpent
from simserpent.envs import SimSerpentVectorEnv

QUIET = {"env.reset_noise_scale": 0.0, "env.reset_heading_noise_rad": 0.0}


def parse_sets(items):
    """``["key=value", ...]`` (the CLI's ``--set``: value a TOML literal; a bare word that is
    not TOML is taken as a string) as an overrides dict, in order."""
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise SystemExit(f"--set/--with {item!r}: expected key=value, e.g. estimation.enabled=true")
        try:
            out[key] = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            out[key] = value.strip()
    return out


def describe(overrides):
    return ", ".join(f"{k} = {simserpent.toml_literal(v)}" for k, v in overrides.items())


def timed(step, reset, seconds):
    """(env steps per wall second, env steps per CPU second of this process): on a shared,
    loaded machine the second is the one-core figure (a vector env on k threads uses up to k
    CPUs, so its CPU figure is per core)."""
    reset()
    n, t0, c0 = 0, time.perf_counter(), time.process_time()
    while True:
        for _ in range(50):
            if step():
                reset()
            n += 1
        dt = time.perf_counter() - t0
        if dt >= seconds:
            return np.array([n / dt, n / max(time.process_time() - c0, 1e-9)])


def single(overrides, actions, seconds):
    env = gym.make("SimSerpent-v0", overrides={**overrides, "env.max_episode_secs": 1000.0})
    k = [0]

    def step():
        k[0] += 1
        _, _, te, tr, _ = env.step(actions[k[0] % len(actions)])
        return te or tr

    return lambda: timed(step, lambda: env.reset(seed=0), seconds)


def vector(overrides, actions, seconds, threads):
    vec = SimSerpentVectorEnv(num_envs=8, overrides={**overrides, "env.max_episode_secs": 1000.0}, threads=threads)
    batches = actions[: (len(actions) // 8) * 8].reshape(-1, 8, actions.shape[1])
    k = [0]

    def step():
        k[0] += 1
        vec.step(batches[k[0] % len(batches)])
        return False

    return lambda: 8 * timed(step, lambda: vec.reset(seed=0), seconds)


def swimmer(seconds):
    env = gym.make("Swimmer-v5")
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, size=(4096, 2)).astype(np.float32)
    k = [0]

    def step():
        k[0] += 1
        _, _, te, tr, _ = env.step(acts[k[0] % 4096])
        return te or tr

    return lambda: timed(step, lambda: env.reset(seed=0), seconds)


def machine():
    """CPU model, number of CPUs and the 1-minute load average (the machine may be shared)."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            model = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return {"cpu": model, "cpus": os.cpu_count(), "load_average_1min": os.getloadavg()[0]}


def throughput(a):
    """Env steps/s (wall and per CPU-second) of each variant, best of ``--repeats`` rounds
    (round-robin), and a markdown table ready to paste into BENCHMARKS.md."""
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(4096, 9)).astype(np.float32)
    sets, extra = parse_sets(a.set), parse_sets(a.with_)
    kinds = [("", {})] + ([(f", {describe(extra)}", extra)] if extra else [])
    variants = []
    for preset in ["default", "fast"]:
        for tag, more in kinds:
            o = {"env.preset": preset, **sets, **more}
            variants.append((f"SimSerpent-v0, `preset = \"{preset}\"`{tag}", single(o, actions, a.seconds)))
    for preset in ["default", "fast"]:
        for threads in (1, 2):
            for tag, more in kinds:
                o = {"env.preset": preset, **sets, **more}
                s = "s" if threads > 1 else ""
                name = f"Rust vector env, 8 envs, {threads} thread{s}, `preset = \"{preset}\"`{tag}"
                variants.append((name, vector(o, actions, a.seconds, threads)))
    try:
        variants.append(("Gymnasium Swimmer-v5 (same `mujoco` wheel)", swimmer(a.seconds)))
    except Exception as e:  # pragma: no cover - gymnasium[mujoco] extras
        print(f"Swimmer-v5 not available: {e}")
    if a.only:
        variants = [(n, f) for n, f in variants if any(o in n for o in a.only)]
        if not variants:
            raise SystemExit(f"--only {a.only}: no variant matches")
    loads = [os.getloadavg()[0]]
    results: dict[str, list[float]] = {}
    for _ in range(a.repeats):
        for name, fn in variants:
            results[name] = np.maximum(results.get(name, np.zeros(2)), fn()).tolist()
            loads.append(os.getloadavg()[0])
    m = machine()
    print(
        f"\n{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {m['cpu']}, {m['cpus']} CPUs; "
        f"1-minute load average during the run {min(loads):.1f}-{max(loads):.1f}; "
        f"best of {a.repeats} rounds of {a.seconds:g} s; fast preset = {', '.join(simserpent.ENV_FAST_PRESET)}"
        + (f"; every SimSerpent variant with {describe(sets)}" if sets else "")
        + "\n"
    )
    print("| variant (10-link default snake, random actions) | env steps/s, wall | env steps per CPU-second |")
    print("|---|---:|---:|")
    for name, _ in variants:
        wall, cpu = results[name]
        print(f"| {name} | {wall:,.0f} | {cpu:,.0f} |", flush=True)
    return {"variants": results, "machine": m, "load_average_1min": [min(loads), max(loads)], "set": sets,
            "with": extra}


def reference_gait(overrides, secs, episodes=8, first_seed=0):
    """The reference gait from ``episodes`` starts (the default [env] reset noise, seeds 0, 1,
    ...; one snake each in a vector env): per start the speed of travel (|displacement of the
    centre of mass| after the 1 s ramp / time), the heading of travel (rad) and the mean of the
    per-action peak contact force (N); their means over the starts with standard errors, and
    env steps/s."""
    cfg = simserpent.load_config(overrides={**overrides, "env.max_episode_secs": secs})
    vec = SimSerpentVectorEnv(num_envs=episodes, config=cfg, threads=0)
    gait = simserpent.Gait(cfg)
    vec.reset(seed=list(range(first_seed, first_seed + episodes)))
    dt = vec.dt
    n = int(round(secs / dt))
    start = int(round(1.0 / dt))  # after the ramp
    xy0 = None
    peaks = []
    t0 = time.perf_counter()
    for k in range(n):
        a = np.tile(gait.action(k * dt), (episodes, 1))
        _, _, term, _, info = vec.step(a)
        if term.any():
            return {"error": str(info.get("error"))}
        if k == start:
            xy0 = np.stack([info["x_position"], info["y_position"]], axis=1)
        if k >= start:
            peaks.append(info["peak_contact_force_n"])
    wall = time.perf_counter() - t0
    xy1 = np.stack([info["x_position"], info["y_position"]], axis=1)
    d = xy1 - xy0
    span = (n - 1 - start) * dt
    speed = np.hypot(d[:, 0], d[:, 1]) / span
    heading = np.arctan2(d[:, 1], d[:, 0])
    force = np.mean(peaks, axis=0)

    def stat(x):
        return float(np.mean(x)), float(np.std(x, ddof=1) / np.sqrt(len(x)))

    (s, s_se), (h, h_se), (f, f_se) = stat(speed), stat(heading), stat(force)
    return {
        "speed_m_per_s": s, "speed_se": s_se,
        "heading_rad": h, "heading_se": h_se,
        "mean_peak_contact_force_n": f, "force_se": f_se,
        "env_steps_per_s_vector": episodes * n / wall,
    }


def candidate_overrides(name):
    """``default``, ``fast``, ``perturbed`` or ``integrator@timestep_ms``; any of them may end
    in ``:contact_ms``, which fixes ``physics.environment_contact_time_constant_secs`` (the
    link-obstacle and link-ground contact time constant, default "auto" = max(2 ms, 2 timesteps))
    at that many ms instead (MuJoCo needs at least 2 timesteps)."""
    name, _, contact_ms = name.partition(":")
    extra = {}
    if contact_ms:
        extra["physics.environment_contact_time_constant_secs"] = float(contact_ms) / 1000.0
    if name == "default":
        return extra
    if name == "fast":
        return {"env.preset": "fast", **extra}
    if name.startswith("perturbed"):
        # The default physics from a start perturbed by 1e-6 rad: the noise floor of the metrics.
        return {"env.reset_noise_scale": 1e-6, **extra}
    integrator, ms = name.split("@")
    dt = float(ms) / 1000.0
    return {
        "general.integrator": integrator,
        "general.timestep_secs": dt,
        "physics.floor_stick_time_constant_secs": max(0.005, 5 * dt),
        **extra,
    }


def accuracy(a):
    out = {}
    sets = parse_sets(a.set)
    for floor in a.floors.split(","):
        base = {"physics.floor_friction": floor, **sets}
        ref = reference_gait(base, a.secs, a.episodes, a.first_seed)
        out[floor] = {"default": ref}
        print(f"floor {floor}: default physics: {ref}")
        for name in a.candidates.split(","):
            if name == "default":
                continue
            r = reference_gait({**base, **candidate_overrides(name)}, a.secs, a.episodes, a.first_seed)
            if "error" not in r:
                r["speed_diff_percent"] = 100 * (r["speed_m_per_s"] / ref["speed_m_per_s"] - 1)
                r["heading_diff_rad"] = r["heading_rad"] - ref["heading_rad"]
                r["force_diff_percent"] = 100 * (r["mean_peak_contact_force_n"] / ref["mean_peak_contact_force_n"] - 1)
            out[floor][name] = r
            print(f"floor {floor}: {name}: {r}", flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["throughput", "accuracy"])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--secs", type=float, default=10.0)
    ap.add_argument("--floors", default="stick_slip,mujoco")
    ap.add_argument("--episodes", type=int, default=16, help="starts per physics (accuracy)")
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first_seed, first_seed + 1, ... (accuracy)")
    ap.add_argument(
        "--candidates",
        default="fast,RK4@2,implicitfast@2,implicitfast@4,Euler@2,implicitfast@5",
    )
    ap.add_argument("--json")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="config override for every SimSerpent variant (repeatable), e.g. estimation.enabled=true")
    ap.add_argument("--with", dest="with_", action="append", default=[], metavar="KEY=VALUE",
                    help="throughput: also measure every SimSerpent variant with this override (repeatable)")
    ap.add_argument("--only", action="append", default=[], metavar="SUBSTRING",
                    help="throughput: only the variants whose name contains this (repeatable)")
    a = ap.parse_args()
    results = throughput(a) if a.what == "throughput" else accuracy(a)
    results = {"results": results, "setup": {**machine(), "python": platform.python_version(),
                                            "fast_preset": simserpent.ENV_FAST_PRESET}}
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()

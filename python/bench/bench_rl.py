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

throughput: env steps per second (wall, and per CPU-second of this process and its children) of
  - ``gym.make("SimSerpent-v0")`` (the 10-link default snake and terrain, random actions in
    [-1, 1]) with the default physics and with ``env.preset = "fast"``;
  - the Rust vector env (``SimSerpentVectorEnv``) of 2, 4 and 8 envs on all cores, and of 8
    envs on 1 thread (default and fast);
  - Gymnasium's ``SyncVectorEnv`` and ``AsyncVectorEnv`` of 8 ``SimSerpent-v0`` (fast);
  - Gymnasium's ``Swimmer-v5`` and ``Ant-v5`` (``gymnasium[mujoco]``), one env and
    ``AsyncVectorEnv`` of 8.
  The speed-up column is the wall-clock env steps/s over one ``SimSerpent-v0`` of the same
  preset (for Gymnasium's envs: over one env of the same kind); "CPU cores used" is CPU time
  over wall time (what the scheduler gave the process: on a loaded machine with
  ``sched_autogroup`` the share is per autogroup, not per thread, so more threads get no more CPU).
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
    n, t0, c0 = 0, time.perf_counter(), cpu_secs()
    while True:
        for _ in range(50):
            if step():
                reset()
            n += 1
        dt = time.perf_counter() - t0
        if dt >= seconds:
            return np.array([n / dt, n / max(cpu_secs() - c0, 1e-9)])


def cpu_secs():
    """CPU time of this process and its finished-or-running children (AsyncVectorEnv's workers
    are children: their time counts once they report it, so it is read from /proc)."""
    total = time.process_time()
    try:
        me = os.getpid()
        for pid in os.listdir("/proc"):
            if not pid.isdigit():
                continue
            try:
                with open(f"/proc/{pid}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == me:  # ppid
                total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except OSError:
        pass
    return total


def single(overrides, actions, seconds):
    env = gym.make("SimSerpent-v0", overrides={**overrides, "env.max_episode_secs": 1000.0})
    k = [0]

    def step():
        k[0] += 1
        _, _, te, tr, _ = env.step(actions[k[0] % len(actions)])
        return te or tr

    return lambda: timed(step, lambda: env.reset(seed=0), seconds)


def vector(overrides, actions, seconds, threads, n=8):
    vec = SimSerpentVectorEnv(num_envs=n, overrides={**overrides, "env.max_episode_secs": 1000.0}, threads=threads)
    batches = actions[: (len(actions) // n) * n].reshape(-1, n, actions.shape[1])
    k = [0]

    def step():
        k[0] += 1
        vec.step(batches[k[0] % len(batches)])
        return False

    return lambda: n * timed(step, lambda: vec.reset(seed=0), seconds)


def gym_vector(env_id, mode, seconds, n=8, **kwargs):
    """Gymnasium's SyncVectorEnv or AsyncVectorEnv (``mode`` "sync" or "async") of ``n``
    environments ``env_id`` (autoreset inside; random actions from the action space)."""
    vec = gym.make_vec(env_id, num_envs=n, vectorization_mode=mode, **kwargs)
    rng = np.random.default_rng(0)
    space = vec.single_action_space
    acts = rng.uniform(space.low, space.high, size=(256, n, *space.shape)).astype(space.dtype)
    k = [0]

    def step():
        k[0] += 1
        vec.step(acts[k[0] % 256])
        return False

    return lambda: n * timed(step, lambda: vec.reset(seed=0), seconds)


def gym_single(env_id, seconds):
    env = gym.make(env_id)
    rng = np.random.default_rng(0)
    space = env.action_space
    acts = rng.uniform(space.low, space.high, size=(4096, *space.shape)).astype(space.dtype)
    k = [0]

    def step():
        k[0] += 1
        _, _, te, tr, _ = env.step(acts[k[0] % 4096])
        return te or tr

    return lambda: timed(step, lambda: env.reset(seed=0), seconds)


def swimmer(seconds):
    return gym_single("Swimmer-v5", seconds)


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
    cores = os.cpu_count() or 1
    baseline = {}
    for preset in ["default", "fast"]:
        baseline[f"SimSerpent-v0, `preset = \"{preset}\"`"] = preset
        for n, threads in ((8, 1), (2, 0), (4, 0), (8, 0)):
            for tag, more in kinds:
                o = {"env.preset": preset, **sets, **more}
                where = "1 thread" if threads == 1 else f"{cores} threads"
                name = f"Rust vector env, {n} envs, {where}, `preset = \"{preset}\"`{tag}"
                variants.append((name, vector(o, actions, a.seconds, threads, n)))
                baseline[name] = preset
    fast = {"env.preset": "fast", **sets}
    for mode in ("sync", "async"):
        name = f"Gymnasium {mode.capitalize()}VectorEnv, 8 SimSerpent-v0, `preset = \"fast\"`"
        variants.append((name, gym_vector("SimSerpent-v0", mode, a.seconds, overrides=fast)))
        baseline[name] = "fast"
    for env_id in ("Swimmer-v5", "Ant-v5"):
        try:
            variants.append((f"Gymnasium {env_id}", gym_single(env_id, a.seconds)))
            variants.append((f"Gymnasium AsyncVectorEnv, 8 {env_id}", gym_vector(env_id, "async", a.seconds)))
            baseline[f"Gymnasium AsyncVectorEnv, 8 {env_id}"] = f"Gymnasium {env_id}"
        except Exception as e:  # pragma: no cover - gymnasium[mujoco] extras
            print(f"{env_id} not available: {e}")
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
    print("| variant (10-link default snake, random actions) | env steps/s, wall | env steps per CPU-second "
          "| CPU cores used | speed-up over one env (wall) |")
    print("|---|---:|---:|---:|---:|")
    for name, _ in variants:
        wall, cpu = results[name]
        base = baseline.get(name)
        if base in ("default", "fast"):
            base = f"SimSerpent-v0, `preset = \"{base}\"`"
        ratio = f"{wall / results[base][0]:.2f}" if base in results and base != name else ""
        print(f"| {name} | {wall:,.0f} | {cpu:,.0f} | {wall / cpu:.2f} | {ratio} |", flush=True)
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

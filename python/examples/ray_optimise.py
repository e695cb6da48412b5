"""Cross-entropy search over the sine-wave gait for forward speed, on a Ray cluster.

    python python/examples/ray_optimise.py                  # local Ray cluster on all cores
    python python/examples/ray_optimise.py --address auto   # an existing cluster

Each candidate is a whole simulation (one run folder) run as a Ray task; each iteration refits
a Gaussian over (frequency, amplitude, phase lag) to the fastest quarter. Also shows a grid
sweep with the same summary table as `simserpent sweep`.
"""

import argparse

from simserpent import ray_sweep

ap = argparse.ArgumentParser()
ap.add_argument("--address", default=None, help="Ray cluster address (default: a local cluster)")
ap.add_argument("--iterations", type=int, default=3)
ap.add_argument("--population", type=int, default=8)
ap.add_argument("--out", default="runs/ray-example")
a = ap.parse_args()

BASE = [
    "snake.n_links=8",
    'terrain.kind="none"',
    "general.duration_secs=4.0",
    "recording.enabled=false",
]

result = ray_sweep.cross_entropy(
    {
        "gait.sine_wave.frequency_hz": (0.2, 2.0),
        "gait.sine_wave.amplitude_deg": (10.0, 60.0),
        "gait.sine_wave.phase_lag_deg": (10.0, 90.0),
    },
    overrides=BASE,
    iterations=a.iterations,
    population=a.population,
    seed=0,
    out_dir=f"{a.out}/cross-entropy",
    address=a.address,
)
hist = result["history"]
print(hist.groupby("iteration")["forward_speed_m_per_s"].agg(["mean", "max"]).round(4))
print("best:", {k: round(v, 2) for k, v in result["best_params"].items()}, f"{result['best_value']:.4f} m/s")
print("all candidates:", result["csv"])

df, csv = ray_sweep.sweep(
    vary=["gait.sine_wave.frequency_hz=0.5,1.0,1.5"],
    overrides=BASE,
    sweep_dir=f"{a.out}/sweep",
    address=a.address,
)
print(df[["run_id", "status", "forward_speed_m_per_s"]])
print("summary:", csv)

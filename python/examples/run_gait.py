"""Notebook-style example: run a gait, then plot from the recorded tables with matplotlib.

    python python/examples/run_gait.py [output_folder]

Writes the run folder (tables, manifest, model.xml) and `gait.png` into `output_folder`
(default `runs/example-gait`).
"""

# %% Setup
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402

import simserpent  # noqa: E402

out = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/example-gait")

# %% A 10-link snake undulating on anisotropic friction (lateral 1.0, axial 0.1), 6 s
config = simserpent.load_config(
    {
        "snake": {"n_links": 10},
        "terrain": {"kind": "none"},
        "ground": {"model": "anisotropic", "axial_friction": 0.1, "lateral_friction": 1.0},
        "gait": {"kind": "sine_wave", "sine_wave": {"amplitude_deg": 30.0, "frequency_hz": 1.0}},
    },
    overrides={"general.duration_secs": 6.0, "recording.every_n_steps": 10},
)
summary = simserpent.run(config, run_folder=out / "run")
print(f"forward speed {summary['forward_speed_m_per_s']:.4f} m/s, energy {summary['actuator_energy_j']:.2f} J")

# %% Open the run folder: every table is a pandas DataFrame
run = simserpent.open_run(summary["run_folder"])
links, joints = run.links, run.joints
print(run)

# %% Plot: the path of every link seen from above, and the joint angles over time
fig, (top, angles) = plt.subplots(1, 2, figsize=(12, 4.5))
n_links = 10
for i in range(n_links):
    top.plot(links[f"link_{i:02d}_position_x_m"], links[f"link_{i:02d}_position_y_m"], lw=0.8)
top.set_xlabel("x (m)")
top.set_ylabel("y (m)")
top.set_title("link paths (top view)")
top.set_aspect("equal", adjustable="datalim")
angle_columns = [c for c in joints.columns if c.endswith("_angle_rad")]
for c in angle_columns[:4]:
    angles.plot(joints["time_s"], joints[c], label=c.replace("_angle_rad", ""))
angles.set_xlabel("time (s)")
angles.set_ylabel("joint angle (rad)")
angles.set_title("joint angles")
angles.legend(loc="upper right", fontsize="small")
fig.tight_layout()
png = out / "gait.png"
fig.savefig(png, dpi=100)
print(f"wrote {png}")

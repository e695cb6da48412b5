"""Restitution measured by the same impact test in both engines, and Drake's damping set from it.

SimSerpent's floor and obstacles damp with MuJoCo's soft-contact damper (and its step), Drake's
point contact with Hunt–Crossley, f = k·x·(1 + d·ẋ), whose restitution depends on the impact
speed. Neither is set from a formula here: each scene's impacts are reproduced as a test on one
link, run in SimSerpent at the scene's timestep, and Drake's dissipation d is the one whose same
test (the same MJCF, built by `drake_side`) rebounds with the same restitution.

- floor test: one link lying flat, 0.1 mm above the floor, falling at the scene's impact speed;
- obstacle test: one link lying on the floor, broadside at 0.5 mm from the scene's obstacle
  (a cylinder or the mesh, its centre level with the link's), moving at the scene's impact speed.

The restitution is the normal speed at the first row after the contact opens again over the
normal speed at the last row before it closed (0 when it does not open again within the test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# A contact is closed while its force exceeds this share of the link's weight.
CONTACT_SHARE_OF_WEIGHT = 1e-3
FLOOR_GAP_M = 1e-4
OBSTACLE_GAP_M = 5e-4


@dataclass(frozen=True)
class ImpactTest:
    """One impact test: `kind` "floor" or "obstacle"; the obstacle a cylinder of `radius_m`, or
    the mesh of `mesh_file` (a file name in the suite's work folder: a vertical prism of that
    circumradius, its axis at the origin)."""

    kind: str
    speed_m_per_s: float
    radius_m: float = 0.0
    mesh_file: str = ""

    def label(self) -> str:
        if self.kind == "floor":
            return f"floor at {self.speed_m_per_s:.3g} m/s"
        what = "mesh prism" if self.mesh_file else "cylinder"
        return f"{what} (radius {self.radius_m:g} m) at {self.speed_m_per_s:.3g} m/s"


def simserpent_sets(test: ImpactTest, mu: float, timestep_secs: float, files_dir=None, link_radius_m: float = 0.04,
                    link_length_m: float = 0.2) -> dict:
    """The config keys of the test (one link; its head tip at the origin, body along -x); a mesh
    obstacle's file is in `files_dir`."""
    sets = {
        "general.duration_secs": 0.1 if test.kind == "floor" else 0.05,
        "general.timestep_secs": timestep_secs,
        "recording.every_n_steps": 1,
        "control.controller": "gait",
        "gait.kind": "none",
        "ground.model": "isotropic",
        "snake.n_links": 1,
        "snake.ground_friction": [mu, 0.0, 0.0],
        "snake.link_friction": [mu, 0.0, 0.0],
        "terrain.obstacle_friction": [mu, 0.0, 0.0],
        "terrain.kind": "none",
    }
    if test.kind == "floor":
        sets["snake.head_position_m"] = [0.0, 0.0, FLOOR_GAP_M]
        sets["initial_state.linear_velocity_m_per_s"] = [0.0, 0.0, -test.speed_m_per_s]
        return sets
    centre = [-link_length_m / 2, link_radius_m + OBSTACLE_GAP_M + test.radius_m]
    sets["initial_state.linear_velocity_m_per_s"] = [0.0, test.speed_m_per_s, 0.0]
    if test.mesh_file:
        from simserpent_side import Raw

        sets["terrain.mesh_obstacles"] = Raw(
            f'[{{file = "{Path(files_dir) / test.mesh_file}", position_m = [{centre[0]!r}, {centre[1]!r}, 0.0]}}]')
    else:
        sets.update({"terrain.pegboard.layout": "square", "terrain.pegboard.region_min_m": centre,
                     "terrain.pegboard.region_max_m": centre, "terrain.pegboard.peg_radius_m": test.radius_m,
                     "terrain.pegboard.spacing_m": 2 * test.radius_m + 0.1})
    return sets


def measure(run: dict, model, kind: str) -> float:
    """Restitution of the first impact of link 0 in a run of an impact test."""
    weight = model.link_weight_n(0)
    force = run["floor_force" if kind == "floor" else "obstacle_force"][:, 0]
    closed = np.linalg.norm(force, axis=1) > CONTACT_SHARE_OF_WEIGHT * weight
    closed[0] = False
    first = np.nonzero(closed)[0]
    if len(first) == 0:
        raise ValueError(f"the {kind} impact test never touches")
    c0 = int(first[0])
    normal = force[c0] / np.linalg.norm(force[c0])
    v = run["velocity"][:, 0] @ normal
    v_in = -float(v[c0 - 1])
    if v_in <= 0:
        raise ValueError(f"the {kind} impact test does not approach (normal speed {v_in:.3g} m/s)")
    opened = np.nonzero(~closed[c0:])[0]
    if len(opened) == 0:
        return 0.0
    return max(0.0, float(v[c0 + int(opened[0])])) / v_in


def calibrate(drake_restitution, target: float, first_guess: float, iterations: int = 9) -> tuple[float, float]:
    """The dissipation d (s/m) whose Drake restitution `drake_restitution(d)` equals `target`
    (bisection in log d; the restitution falls as d rises). Returns (d, Drake's restitution at d)."""
    lo, hi = first_guess / 4, first_guess * 4
    e_lo, e_hi = drake_restitution(lo), drake_restitution(hi)
    while e_lo < target and lo > 1e-4:
        hi, e_hi = lo, e_lo
        lo /= 4
        e_lo = drake_restitution(lo)
    while e_hi > target and hi < 1e5:
        lo, e_lo = hi, e_hi
        hi *= 4
        e_hi = drake_restitution(hi)
    best = min(((lo, e_lo), (hi, e_hi)), key=lambda p: abs(p[1] - target))
    for _ in range(iterations):
        mid = math.sqrt(lo * hi)
        e = drake_restitution(mid)
        if abs(e - target) < abs(best[1] - target):
            best = (mid, e)
        if e > target:
            lo = mid
        else:
            hi = mid
    return best


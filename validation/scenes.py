"""The scenes: SimSerpent's `--set` keys, the joint command the reference's servos follow, and the
figures reported for each. Every scene runs on isotropic Coulomb friction μ (0.5 and 1.0) with the
default settings otherwise, recorded every step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

import figures as fg
from mjcf_model import Model

MUS = (0.5, 1.0)

# A snake that starts lying on the floor takes up its weight within this time (SimSerpent starts at
# zero penetration; the reference at its static sink).
SETTLE_SECS = 0.02

# The landing speed of a link that falls 1 mm, the size of the lifts during a gait's ramp (m/s).
LANDING_M_PER_S = math.sqrt(2 * 9.81 * 0.001)

# The default gait, written out so that both engines get exactly these numbers.
GAIT = {"amplitude_deg": 30.0, "frequency_hz": 0.5, "phase_lag_deg": 40.0, "offset_deg": 0.0}
RAMP_SECS = 1.0

# Break-away: the force on link 0 rises as μN · t / BREAKAWAY_RAMP_SECS.
BREAKAWAY_RAMP_SECS = 1.0


def common(mu: float, duration_secs: float) -> dict:
    return {
        "general.duration_secs": duration_secs,
        "recording.every_n_steps": 1,
        "control.controller": "gait",
        "ground.model": "isotropic",
        "snake.ground_friction": [mu, 0.0, 0.0],
        "snake.link_friction": [mu, 0.0, 0.0],
        "terrain.obstacle_friction": [mu, 0.0, 0.0],
        "terrain.kind": "none",
    }


def sine_command(n_joints: int) -> Callable[[float], np.ndarray]:
    """φ_j(t) = r(t)·A·sin(2πf t − j δ), r the smoothstep ramp (SimSerpent's gait::SineWave)."""
    a = math.radians(GAIT["amplitude_deg"])
    w = 2 * math.pi * GAIT["frequency_hz"]
    d = math.radians(GAIT["phase_lag_deg"])
    j = np.arange(n_joints)

    def command(t: float) -> np.ndarray:
        s = min(max(t / RAMP_SECS, 0.0), 1.0)
        r = s * s * (3 - 2 * s)
        return r * a * np.sin(w * t - j * d)

    return command


def hold_command(model: Model) -> Callable[[float], np.ndarray]:
    angles = model.qpos[7:].copy()
    return lambda t: angles


@dataclass
class Scene:
    key: str
    title: str
    what: str
    duration_secs: float
    sets: Callable[[float], dict]
    figures: Callable[[dict, Model], list[tuple[str, object]]]
    gait: bool = False
    push: bool = False
    n_links: int = 10
    # The speed of the scene's impacts (m/s): the reference's Hunt-Crossley dissipation is chosen
    # so that its restitution at this speed is MuJoCo's at the floor's damping ratio.
    impact_speed_m_per_s: float = LANDING_M_PER_S


def ramp_figures(run, model):
    lo, hi = fg.total_load_range(run, model)
    return [
        ("airborne link-steps, ramp 0–1 s (%)", fg.airborne(run, model, 0, 1)),
        ("airborne link-steps, 1–3 s (%)", fg.airborne(run, model, 1, 3)),
        ("airborne per 0.25-s window, 0–2 s (%)", fg.airborne_windows(run, model, 0.25, 2.0)),
        ("largest lift, 0–1 s (mm)", fg.largest_lift_mm(run, model, 0, 1)),
        ("largest lift, 1–3 s (mm)", fg.largest_lift_mm(run, model, 1, 3)),
        ("largest N / m g, 0–1 s", fg.peak_load_per_weight(run, model, 0, 1)),
        ("largest N / m g, 1–3 s", fg.peak_load_per_weight(run, model, 1, 3)),
        ("Σ N / W, smallest … largest", (lo, hi)),
        ("steady undulation (1–3 s): mean N / m g per link, head → tail", list(fg.per_link_load(run, model, 1, 3))),
        ("steady undulation: swing of each link's load (0.1-s mean) / m g", list(fg.per_link_swing(run, model, 1, 3))),
    ]


def motion_figures(windows_until: float):
    def f(run, model):
        lo, hi = fg.total_load_range(run, model)
        out = [
            ("airborne link-steps (%)", fg.airborne(run, model)),
            ("airborne per 0.25-s window (%)", fg.airborne_windows(run, model, 0.25, windows_until)),
            ("largest lift (mm)", fg.largest_lift_mm(run, model)),
            ("largest N / m g", fg.peak_load_per_weight(run, model)),
            ("Σ N / W, smallest … largest", (lo, hi)),
            ("Σ N / W from 20 ms on, smallest … largest", fg.total_load_range(run, model, SETTLE_SECS)),
            ("Σ N / W, mean over the run", fg.total_load_mean(run, model)),
        ]
        if np.abs(run["obstacle_force"]).max() > 0:
            obstacle = np.linalg.norm(run["obstacle_force"][1:].sum(axis=1), axis=1)
            out.append(("largest obstacle force on the snake (N)", float(obstacle.max())))
        return out

    return f


def coasting_figures(run, model):
    e0, de, rise = fg.energy_figures(run, model)
    return motion_figures(2.0)(run, model) + [
        ("energy E(0) (J)", e0),
        ("energy change E(end) − E(0) (J)", de),
        ("largest energy rise in one recorded step (J)", rise),
    ]


def upright_figures(run, model):
    end, largest = fg.top_link_offset_mm(run)
    return [
        ("top link's horizontal offset at the end (mm)", end),
        ("top link's largest horizontal offset (mm)", largest),
        ("largest N / m g", fg.peak_load_per_weight(run, model)),
        ("airborne link-steps of the head, 0.5 s – end (%)", _head_airborne(run, model, 0.5)),
    ]


def _head_airborne(run, model, t0):
    t = run["time_s"]
    sel = t >= t0
    return 100.0 * float((fg.normal_load(run)[sel, 0] < fg.AIRBORNE_SHARE_OF_WEIGHT * model.link_weight_n(0)).mean())


def rest_figures(run, model):
    lo, hi = fg.total_load_range(run, model)
    return [
        ("mean N / m g per link, 0.5–1 s, head → tail", list(fg.per_link_load(run, model, 0.5, 1.0))),
        ("Σ N / W, smallest … largest", (lo, hi)),
        ("largest lift (mm)", fg.largest_lift_mm(run, model)),
    ]


def breakaway_figures(run, model):
    return [("break-away force / μN (ramp μN per 1 s)", fg.breakaway_ratio(run, model, BREAKAWAY_RAMP_SECS))]


def _launch(velocity, angular=(0.0, 0.0, 0.0)):
    return {
        "gait.kind": "none",
        "initial_state.linear_velocity_m_per_s": list(velocity),
        "initial_state.angular_velocity_rad_per_s": list(angular),
    }


SCENES = [
    Scene(
        "ramp", "Gait ramp start and steady undulation",
        "The default 10-link snake, the default gait (sine wave 30°, 0.5 Hz, 40° lag) with its 1-s amplitude "
        "ramp, on the bare floor, 3 s.",
        3.0, lambda mu: {**{f"gait.sine_wave.{k}": v for k, v in GAIT.items()}, "gait.kind": "sine_wave",
                         "gait.ramp_secs": RAMP_SECS}, ramp_figures, gait=True,
    ),
    Scene(
        "launch", "Sideways launch",
        "A straight 10-link snake launched at 5 m/s along its normal (+y), servos holding it straight, 1 s.",
        1.0, lambda mu: _launch((0.0, 5.0, 0.0)), motion_figures(1.0),
    ),
    Scene(
        "hit", "Sideways hit on the cylinders",
        "As the sideways launch, into the two-cylinder terrain of the thesis' collision experiment "
        "(`terrain.kind = \"two_cylinders\"`, distance 0.3 m, radius 0.2 m: one cylinder beside the middle of the "
        "body, the other ahead of the head), 1 s.",
        1.0, lambda mu: {**_launch((0.0, 5.0, 0.0)), "terrain.kind": "two_cylinders",
                         "terrain.two_cylinders.distance_m": 0.3, "terrain.two_cylinders.radius_m": 0.2},
        motion_figures(1.0), impact_speed_m_per_s=5.0,
    ),
    Scene(
        "upright", "Upright snake",
        "The straight snake standing on its head tip (`snake.head_rotation_deg = [0, 90, 0]`), servos holding; "
        "it starts with the tip 40 mm above the floor (the lowest start the model generator accepts) and drops "
        "onto it; 2 s.",
        2.0, lambda mu: {"gait.kind": "none", "snake.head_rotation_deg": [0.0, 90.0, 0.0]}, upright_figures,
        impact_speed_m_per_s=math.sqrt(2 * 9.81 * 0.04),
    ),
    Scene(
        "coasting", "Coasting",
        "Motors off (`control.method = \"torque\"`, PID gains 0; joint damping and armature stay), the straight "
        "snake launched at 1 m/s along +y spinning at 2 rad/s about the vertical through its head tip, 2 s.",
        2.0, lambda mu: {**_launch((0.0, 1.0, 0.0), (0.0, 0.0, 2.0)), "control.method": "torque",
                         "control.pid_kp_nm_per_rad": 0.0, "control.pid_ki_nm_per_rad_s": 0.0,
                         "control.pid_kd_nm_s_per_rad": 0.0}, coasting_figures,
    ),
    Scene(
        "peg", "Peg impact",
        "The straight snake launched head first at 2 m/s along +x into one peg (radius 0.05 m, centre "
        "(0.1, 0.03) m: 0.05 m ahead of the head tip, 3 cm off its axis), servos holding, 1 s.",
        1.0, lambda mu: {**_launch((2.0, 0.0, 0.0)), "terrain.pegboard.layout": "square",
                         "terrain.pegboard.region_min_m": [0.1, 0.03], "terrain.pegboard.region_max_m": [0.1, 0.03],
                         "terrain.pegboard.peg_radius_m": 0.05}, motion_figures(1.0), impact_speed_m_per_s=2.0,
    ),
    Scene(
        "breakaway", "Break-away under a slowly ramped force",
        "One link on the floor, pushed along +x at its centre of mass by F(t) = μ m g · t / 1 s; the "
        "break-away force from the first step faster than 1 mm/s (see `figures.breakaway_ratio`), 1.5 s.",
        1.5, lambda mu: {"gait.kind": "none", "snake.n_links": 1}, breakaway_figures, push=True, n_links=1,
    ),
    Scene(
        "rest", "Straight snake at rest",
        "The straight 10-link snake lying on the floor, servos holding, 1 s: how the floor shares its weight.",
        1.0, lambda mu: {"gait.kind": "none"}, rest_figures,
    ),
]


def overrides(scene: Scene, mu: float) -> dict:
    return {**common(mu, scene.duration_secs), **scene.sets(mu)}

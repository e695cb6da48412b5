"""The scenes: SimSerpent's `--set` keys, the joint command the reference's servos follow, the
impacts whose restitution sets the reference's damping, and the figures reported for each. Every
scene runs on isotropic Coulomb friction μ (0.5 and 1.0) with the default settings otherwise,
recorded every step.

Every figure is computed at one sampling for every engine: the reference (Drake, 0.1-ms steps)
and SimSerpent at a finer convergence step are resampled to SimSerpent's own step
(`figures.resample`: states at its rows, forces as the mean over each of its steps) before any
figure is taken; force peaks are also given as the largest mean over a 10-ms window.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

import figures as fg
from drake_side import Ground
from mjcf_model import Model
from restitution import ImpactTest

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



# The 1° tilt of the perturbed upright snake, and the top link's horizontal offset that counts as
# toppled (m).
TILT_DEG = 1.0
TOPPLE_OFFSET_M = 0.2

# Heightfield scenes: a 3 m x 2 m heightfield (2-cm grid) under the default snake, its flat part
# GROUND_Z_M above the floor; the bumpy one carries BUMPS, spherical caps (centre x, y; sphere
# radius; cap height), which the reference builds as spheres buried in its plane.
HF_CENTRE_M = (-1.0, 0.0)
HF_SIZE_M = (3.0, 2.0)
HF_PIXELS = (151, 101)
HF_HEIGHT_M = 0.04
GROUND_Z_M = 0.02
BUMPS = [((x, y), 0.5, 0.01) for x in (-0.3, -0.9, -1.5) for y in (-0.15, 0.15)]
# The bumpy heightfield's starts (a chaotic scene, see Scene.ensemble).
BUMPS_ENSEMBLE = 16

# Mesh scene: a vertical prism of MESH_SIDES sides (circumradius MESH_RADIUS_M), as an OBJ file.
MESH_SIDES = 32
MESH_RADIUS_M = 0.05
MESH_HEIGHT_M = 0.3


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
    # The scene's impacts on the floor (m/s) and on its obstacle: SimSerpent's restitution in
    # these tests sets the reference's floor and obstacle damping (restitution.py).
    floor_impact_m_per_s: float = LANDING_M_PER_S
    obstacle_test: ImpactTest | None = None
    # SimSerpent's finer step of the convergence column (s).
    fine_step_secs: float = 5e-4
    # The surface a heightfield samples (the reference builds it), and files the scene needs.
    ground: Ground | None = None
    prepare: Callable[[Path], dict] | None = None
    tags: tuple = field(default_factory=tuple)
    # Starts per engine and step: 1, or for a chaotic scene (one whose figures a nanometre's
    # change of the start moves by more than its bounds) the number of starts whose figures are
    # averaged; start k has the head fg.ENSEMBLE_OFFSET_M · k aside (fg.perturbed).
    ensemble: int = 1


def gait_figures(run, model):
    lo, hi = fg.total_load_range(run, model)
    return [
        ("airborne link-steps, ramp 0–1 s (%)", fg.airborne(run, model, 0, 1)),
        ("airborne link-steps, 1–3 s (%)", fg.airborne(run, model, 1, 3)),
        ("steps with every link off the floor, 0–3 s", fg.all_links_off_steps(run, model)),
        ("largest lift, 0–1 s (mm)", fg.largest_lift_mm(run, model, 0, 1)),
        ("largest lift, 1–3 s (mm)", fg.largest_lift_mm(run, model, 1, 3)),
        ("largest N / m g in a step, 0–1 s", fg.peak_load_per_weight(run, model, 0, 1)),
        ("largest 10-ms-window N / m g, 0–1 s", fg.largest_window_load(run, model, 0.01, 0, 1)),
        ("largest N / m g in a step, 1–3 s", fg.peak_load_per_weight(run, model, 1, 3)),
        ("largest 10-ms-window N / m g, 1–3 s", fg.largest_window_load(run, model, 0.01, 1, 3)),
        ("Σ N / W, smallest … largest", (lo, hi)),
        ("steady undulation (1–3 s): mean N / m g per link, head → tail", list(fg.per_link_load(run, model, 1, 3))),
        ("centre of mass: mean horizontal speed, 1–3 s (mm/s)", fg.com_speed_mm_per_s(run, model, 1, 3)),
        ("centre of mass: displacement x, y over the run (mm)", fg.com_displacement_mm(run, model)),
    ]


def motion_figures(run, model):
    lo, hi = fg.total_load_range(run, model)
    out = [
        ("airborne link-steps (%)", fg.airborne(run, model)),
        ("steps with every link off the floor", fg.all_links_off_steps(run, model)),
        ("largest lift (mm)", fg.largest_lift_mm(run, model)),
        ("largest N / m g in a step", fg.peak_load_per_weight(run, model)),
        ("largest 10-ms-window N / m g", fg.largest_window_load(run, model)),
        ("Σ N / W, smallest … largest", (lo, hi)),
        ("Σ N / W from 20 ms on, smallest … largest", fg.total_load_range(run, model, SETTLE_SECS)),
        ("Σ N / W, mean over the run", fg.total_load_mean(run, model)),
    ]
    if np.abs(run["obstacle_force"]).max() > 0:
        obstacle = np.linalg.norm(run["obstacle_force"][1:].sum(axis=1), axis=1)
        out.append(("largest obstacle force on the snake in a step (N)", float(obstacle.max())))
        out.append(("largest 10-ms-window obstacle force on the snake (N)", fg.largest_window_obstacle_force(run)))
    return out


def hit_figures(run, model):
    """The motion figures and what carries the lift: the roll of the body after the hit and the
    centre of mass's rise (figures without targets)."""
    return motion_figures(run, model) + [
        ("roll rate about the head link's axis 10 ms after the first obstacle contact (rad/s)",
         fg.roll_rate_after_hit(run)),
        ("largest rise of the centre of mass (mm)", fg.largest_com_rise_mm(run, model)),
    ]


def coasting_figures(run, model):
    e0, de, rise = fg.energy_figures(run, model)
    return motion_figures(run, model) + [
        ("energy E(0) (J)", e0),
        ("energy change E(end) − E(0) (J)", de),
        ("largest energy rise in one recorded step (J)", rise),
    ]


def upright_figures(run, model):
    when, direction = fg.topple(run, TOPPLE_OFFSET_M)
    end, largest = fg.top_link_offset_mm(run)
    return [
        (f"topple time: top link {TOPPLE_OFFSET_M * 1000:.0f} mm off (s)", when),
        ("topple direction (degrees from +x)", direction),
        ("top link's horizontal offset at the end (mm)", end),
        ("largest 10-ms-window N / m g", fg.largest_window_load(run, model)),
    ]


def breakaway_figures(run, model):
    return [("break-away force / μN (ramp μN per 1 s)", fg.breakaway_ratio(run, model, BREAKAWAY_RAMP_SECS))]


def _launch(velocity, angular=(0.0, 0.0, 0.0)):
    return {
        "gait.kind": "none",
        "initial_state.linear_velocity_m_per_s": list(velocity),
        "initial_state.angular_velocity_rad_per_s": list(angular),
    }


def _gait():
    return {**{f"gait.sine_wave.{k}": v for k, v in GAIT.items()}, "gait.kind": "sine_wave", "gait.ramp_secs": RAMP_SECS}


def write_gray_png16(path: Path, values: np.ndarray) -> Path:
    """A 16-bit grayscale PNG of `values` (rows x cols, 0..1; row 0 is the image's top)."""
    rows, cols = values.shape
    pixels = np.round(np.clip(values, 0.0, 1.0) * 65535).astype(">u2")
    raw = b"".join(b"\x00" + pixels[r].tobytes() for r in range(rows))

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", cols, rows, 16, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)
    return path


def heightfield_ground(bumps) -> Ground:
    """The surface: the plane at GROUND_Z_M, the bumps' spheres below it (cap height h: centre
    h − R above the plane)."""
    return Ground(GROUND_Z_M, tuple(((x, y, GROUND_Z_M + h - r), r) for (x, y), r, h in bumps))


def heightfield_png(path: Path, ground: Ground) -> Path:
    """The ground's heights at the heightfield's grid points, as the image the config reads (its
    top row at +y, its left column at -x; gray 1 = HF_HEIGHT_M)."""
    cols, rows = HF_PIXELS
    x = HF_CENTRE_M[0] + (np.arange(cols) / (cols - 1) - 0.5) * HF_SIZE_M[0]
    y = HF_CENTRE_M[1] + (0.5 - np.arange(rows) / (rows - 1)) * HF_SIZE_M[1]
    xx, yy = np.meshgrid(x, y)
    return write_gray_png16(path, ground.height(xx, yy) / HF_HEIGHT_M)


def heightfield_sets(name: str, ground: Ground):
    def prepare(work: Path) -> dict:
        png = heightfield_png(work / f"{name}.png", ground)
        return {
            "terrain.heightfield.file": str(png),
            "terrain.heightfield.center_m": list(HF_CENTRE_M),
            "terrain.heightfield.size_x_m": HF_SIZE_M[0],
            "terrain.heightfield.size_y_m": HF_SIZE_M[1],
            "terrain.heightfield.height_m": HF_HEIGHT_M,
            "snake.head_position_m": [0.0, 0.0, GROUND_Z_M],
        }

    return prepare


def prism_obj(path: Path, sides: int = MESH_SIDES, radius: float = MESH_RADIUS_M, height: float = MESH_HEIGHT_M) -> Path:
    """A vertical prism of `sides` sides (circumradius `radius`), standing on z = 0, axis at the origin."""
    with path.open("w") as f:
        for z in (0.0, height):
            for k in range(sides):
                a = 2 * math.pi * k / sides
                f.write(f"v {radius * math.cos(a)!r} {radius * math.sin(a)!r} {z!r}\n")
        f.write("f " + " ".join(str(k + 1) for k in reversed(range(sides))) + "\n")
        f.write("f " + " ".join(str(sides + k + 1) for k in range(sides)) + "\n")
        for k in range(sides):
            a, b = k + 1, (k + 1) % sides + 1
            f.write(f"f {a} {b} {sides + b} {sides + a}\n")
    return path


def mesh_peg_sets(work: Path) -> dict:
    obj = prism_obj(work / "peg.obj")
    return {"terrain.mesh_obstacles": _raw(f'[{{file = "{obj}", position_m = [0.1, 0.03, 0.0]}}]')}


def _raw(text: str):
    from simserpent_side import Raw

    return Raw(text)


FLAT = heightfield_ground([])
BUMPY = heightfield_ground(BUMPS)
PEG_TEST = ImpactTest("obstacle", 2.0, radius_m=0.05)

SCENES = [
    Scene(
        "ramp", "Gait ramp start and steady undulation",
        "The default 10-link snake, the default gait (sine wave 30°, 0.5 Hz, 40° lag) with its 1-s amplitude "
        "ramp, on the bare floor, 3 s.",
        3.0, lambda mu: _gait(), gait_figures, gait=True,
    ),
    Scene(
        "launch", "Sideways launch",
        "A straight 10-link snake launched at 5 m/s along its normal (+y), servos holding it straight, 1 s.",
        1.0, lambda mu: _launch((0.0, 5.0, 0.0)), motion_figures,
    ),
    Scene(
        "hit", "Sideways hit on the cylinders",
        "As the sideways launch, into the two-cylinder terrain of the thesis' collision experiment "
        "(`terrain.kind = \"two_cylinders\"`, distance 0.3 m, radius 0.2 m: one cylinder beside the middle of the "
        "body, the other ahead of the head), 1 s.",
        1.0, lambda mu: {**_launch((0.0, 5.0, 0.0)), "terrain.kind": "two_cylinders",
                         "terrain.two_cylinders.distance_m": 0.3, "terrain.two_cylinders.radius_m": 0.2},
        hit_figures, floor_impact_m_per_s=1.4, obstacle_test=ImpactTest("obstacle", 5.0, radius_m=0.2),
        fine_step_secs=1e-4,
    ),
    Scene(
        "upright", "Upright snake, tilted 1°",
        f"The straight snake standing on its head tip, tilted {TILT_DEG:g}° from the vertical "
        f"(`snake.head_rotation_deg = [0, {90 - TILT_DEG:g}, 0]`), servos holding; it starts with the tip 40 mm above "
        "the floor (the lowest start the model generator accepts), drops onto it and topples; 3 s. Toppled: the "
        f"top link's centre {TOPPLE_OFFSET_M * 1000:.0f} mm from where it started.",
        3.0, lambda mu: {"gait.kind": "none", "snake.head_rotation_deg": [0.0, 90.0 - TILT_DEG, 0.0]},
        upright_figures, floor_impact_m_per_s=math.sqrt(2 * 9.81 * 0.04),
    ),
    Scene(
        "coasting", "Coasting",
        "Motors off (`control.method = \"torque\"`, PID gains 0; joint damping and armature stay), the straight "
        "snake launched at 1 m/s along +y spinning at 2 rad/s about the vertical through its head tip, 2 s.",
        2.0, lambda mu: {**_launch((0.0, 1.0, 0.0), (0.0, 0.0, 2.0)), "control.method": "torque",
                         "control.pid_kp_nm_per_rad": 0.0, "control.pid_ki_nm_per_rad_s": 0.0,
                         "control.pid_kd_nm_s_per_rad": 0.0}, coasting_figures, tags=("energy",),
    ),
    Scene(
        "peg", "Peg impact, head first",
        "The straight snake launched head first at 2 m/s along +x into one peg (radius 0.05 m, centre "
        "(0.1, 0.03) m: 0.05 m ahead of the head tip, 3 cm off its axis), servos holding, 1 s.",
        1.0, lambda mu: {**_launch((2.0, 0.0, 0.0)), "terrain.pegboard.layout": "square",
                         "terrain.pegboard.region_min_m": [0.1, 0.03], "terrain.pegboard.region_max_m": [0.1, 0.03],
                         "terrain.pegboard.peg_radius_m": 0.05}, motion_figures, obstacle_test=PEG_TEST,
        fine_step_secs=1e-4,
    ),
    Scene(
        "mesh", "Mesh peg impact, head first",
        f"As the head-first peg impact, the peg a mesh obstacle (`terrain.mesh_obstacles`): a {MESH_SIDES}-sided "
        f"prism of circumradius {MESH_RADIUS_M:g} m from an OBJ file. Both engines collide it as its convex hull "
        "(MuJoCo's mesh collision; Drake's `Convex` shape with point contact, loaded from the same vertices), 1 s.",
        1.0, lambda mu: _launch((2.0, 0.0, 0.0)), motion_figures, prepare=mesh_peg_sets,
        obstacle_test=PEG_TEST, fine_step_secs=1e-4,
    ),
    Scene(
        "breakaway", "Break-away under a slowly ramped force",
        "One link on the floor, pushed along +x at its centre of mass by F(t) = μ m g · t / 1 s; the "
        "break-away force from the first step faster than 1 mm/s (see `figures.breakaway_ratio`), 1.5 s.",
        1.5, lambda mu: {"gait.kind": "none", "snake.n_links": 1}, breakaway_figures, push=True, n_links=1,
    ),
    Scene(
        "hf_flat", "Gait on a flat heightfield",
        f"The ramp scene's gait on a flat heightfield {GROUND_Z_M * 1000:g} mm above the floor "
        f"({HF_SIZE_M[0]:g} m x {HF_SIZE_M[1]:g} m, {HF_PIXELS[0]} x {HF_PIXELS[1]} grid from a 16-bit PNG), 3 s. "
        "The reference's ground is a plane at the heightfield's height (the same surface).",
        3.0, lambda mu: _gait(), gait_figures, gait=True, ground=FLAT, prepare=heightfield_sets("flat", FLAT),
    ),
    Scene(
        "hf_bumps", "Gait on a bumpy heightfield",
        f"As the flat heightfield, with {len(BUMPS)} bumps beside the body: spherical caps 10 mm high (sphere "
        "radius 0.5 m, 0.1 m across the foot) at x = −0.3, −0.9, −1.5 m, y = ±0.15 m, sampled on the 2-cm grid. "
        "The reference builds the same caps as spheres (radius 0.5 m) buried in its plane; the grid's vertices "
        "lie on that surface within 0.2 mm (checked), 3 s. Chaotic in SimSerpent (its speed at μ 1 over 16 starts "
        "1 nm apart: 165–224 mm/s at 1 ms, 185–194 mm/s at 0.5 ms; Drake's equal to 6 digits), so every figure is the "
        f"mean over {BUMPS_ENSEMBLE} starts (the head 0, 1, … {BUMPS_ENSEMBLE - 1} nm aside) in each engine, with the "
        "smallest … largest of each number beside it.",
        3.0, lambda mu: _gait(), gait_figures, gait=True, ground=BUMPY, prepare=heightfield_sets("bumps", BUMPY),
        ensemble=BUMPS_ENSEMBLE,
    ),
]


def overrides(scene: Scene, mu: float, prepared: dict | None = None) -> dict:
    return {**common(mu, scene.duration_secs), **scene.sets(mu), **(prepared or {})}




"""SimSerpent's side: `simserpent run` with the scene's `--set` keys, tables read from the run folder."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np


def _set_args(overrides: dict) -> list[str]:
    args = []
    for key, value in overrides.items():
        args += ["--set", f"{key}={_toml(value)}"]
    return args


class Raw(str):
    """A value written into `--set KEY=VALUE` as it is (TOML the caller wrote)."""


def _toml(value) -> str:
    if isinstance(value, Raw):
        return str(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(_toml(v) for v in value) + "]"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, int):
        return str(value)
    raise TypeError(f"cannot write {value!r} as TOML")


def write_model(binary: Path, overrides: dict, out: Path) -> Path:
    """The MJCF the config generates (`simserpent model`), without running it."""
    out.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([str(binary), "model", *_set_args(overrides), "--output", str(out)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return out


def run(binary: Path, overrides: dict, output_dir: Path, name: str) -> Path:
    """Runs the scene; returns its run folder."""
    output_dir.mkdir(parents=True, exist_ok=True)
    before = set(output_dir.iterdir())
    sets = dict(overrides)
    sets["general.output_dir"] = str(output_dir)
    sets["general.run_name"] = name
    proc = subprocess.run([str(binary), "run", "--quiet", *_set_args(sets)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"simserpent run failed ({proc.returncode}): {proc.stderr.strip()[-2000:]}")
    folders = [p for p in set(output_dir.iterdir()) - before if p.name.startswith(name + "-")]
    if len(folders) != 1:
        raise RuntimeError(f"cannot find the run folder of {name} in {output_dir}")
    return folders[0]


def _read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with path.open() as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return header, data


def read_run(folder: Path, n_links: int, model=None) -> dict:
    """The tables of a run folder in the form `figures` expects."""
    names, links = _read_csv(folder / "links.csv")
    col = {n: k for k, n in enumerate(names)}
    rows = links.shape[0]

    def xyz(quantity: str, unit: str) -> np.ndarray:
        out = np.empty((rows, n_links, 3))
        for i in range(n_links):
            for a, axis in enumerate("xyz"):
                out[:, i, a] = links[:, col[f"link_{i:02d}_{quantity}_{axis}_{unit}"]]
        return out

    quat = np.empty((rows, n_links, 4))
    for i in range(n_links):
        for a, c in enumerate(("qw", "qx", "qy", "qz")):
            quat[:, i, a] = links[:, col[f"link_{i:02d}_orientation_{c}"]]
    run = {
        "time_s": links[:, col["time_s"]],
        "position": xyz("position", "m"),
        "quat": quat,
        "velocity": xyz("velocity", "m_per_s"),
        "angular_velocity": xyz("angular_velocity", "rad_per_s"),
        "floor_force": xyz("floor_force", "n"),
        "obstacle_force": xyz("obstacle_force", "n"),
    }
    n_joints = n_links - 1
    if n_joints > 0:
        jnames, joints = _read_csv(folder / "joints.csv")
        jcol = {n: k for k, n in enumerate(jnames)}
        run["joint_velocity"] = np.column_stack(
            [joints[:, jcol[f"joint_{j:02d}_velocity_rad_per_s"]] for j in range(1, n_links)]
        )
        run["joint_angle"] = np.column_stack([joints[:, jcol[f"joint_{j:02d}_angle_rad"]] for j in range(1, n_links)])
    else:
        run["joint_velocity"] = np.zeros((rows, 0))
        run["joint_angle"] = np.zeros((rows, 0))
    if model is not None:
        run["floor_elastic_j"] = floor_elastic_energy(folder, run, model)
    return run


def floor_elastic_energy(folder: Path, run: dict, model) -> np.ndarray:
    """Energy held in the floor's normal springs per row (J): Σ ½·k·δ² over the link–floor rows of
    `contacts.csv`, with SimSerpent's stiffness of a contact point k = s·m_eff·ω² (m_eff the
    point's effective mass along the normal for the link alone, s = 2 / max(2, the link's
    penetrating points), ω² = min(1/(τζ)², 1/dt²); see `sim::ground`)."""
    import csv

    from figures import capsule_inertia

    omega_sq = min(1.0 / (model.env_time_constant_secs * model.env_damping_ratio) ** 2, 1.0 / model.timestep_secs**2)
    row_of_time = {round(float(t), 9): k for k, t in enumerate(run["time_s"])}
    rot = figures_rotations(run)
    points: dict[tuple[int, int], list[float]] = {}
    with (folder / "contacts.csv").open() as f:
        for r in csv.DictReader(f):
            pair = (r["geom1"], r["geom2"])
            if "floor" not in pair:
                continue
            link_geom = pair[0] if pair[1] == "floor" else pair[1]
            if not link_geom.startswith("link_"):
                continue
            depth = float(r["penetration_m"])
            k = row_of_time.get(round(float(r["time_s"]), 9))
            if depth <= 0.0 or k is None:
                continue
            i = int(link_geom[5:7])
            link = model.links[i]
            p = np.array([float(r[f"position_{a}_m"]) for a in "xyz"])
            n = np.array([float(r[f"normal_{a}"]) for a in "xyz"])
            arm = rot[k, i].T @ (p - run["position"][k, i])
            normal = rot[k, i].T @ n
            inertia = capsule_inertia(link.mass_kg, link.radius_m, link.core_length_m)
            rxn = np.cross(arm, normal)
            m_eff = 1.0 / (1.0 / link.mass_kg + rxn @ np.linalg.solve(inertia, rxn))
            points.setdefault((k, i), []).append(0.5 * m_eff * omega_sq * depth * depth)
    energy = np.zeros(len(run["time_s"]))
    for (k, _), halves in points.items():
        s = 2.0 / max(2, len(halves))
        energy[k] += s * sum(halves)
    return energy


def figures_rotations(run: dict) -> np.ndarray:
    from figures import _rotations

    return _rotations(run)

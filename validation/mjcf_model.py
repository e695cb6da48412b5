"""Reads the model SimSerpent ran (the run folder's `model.xml`, the generated MJCF).

Only what the reference needs: the link chain (capsules, masses, joint axes, limits, damping,
armature), the position servos (kp, kv, torque limits), the floor and the vertical cylinders, the
environment contact `solref`, gravity, and the starting state (keyframe `initial`).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


def _floats(text: str | None) -> list[float]:
    return [float(v) for v in text.split()] if text else []


def euler_xyz_matrix(euler: list[float]) -> np.ndarray:
    """MJCF `euler` with the default eulerseq="xyz": intrinsic rotations about x, then y, then z."""
    a, b, c = euler
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return rx @ ry @ rz


def quat_matrix(q: list[float] | np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@dataclass
class Link:
    name: str
    mass_kg: float
    radius_m: float
    # Capsule core (segment) ends in the link's body frame.
    core_from_m: np.ndarray
    core_to_m: np.ndarray
    # Pose of the body frame in its parent's frame (position; rotation only for the head).
    pos_in_parent_m: np.ndarray
    # Joint to the parent (None for the head, which is free).
    joint_name: str | None = None
    joint_axis: np.ndarray | None = None
    joint_range_rad: tuple[float, float] | None = None
    joint_damping_nm_s_per_rad: float = 0.0
    joint_armature_kg_m2: float = 0.0

    @property
    def core_length_m(self) -> float:
        return float(np.linalg.norm(self.core_to_m - self.core_from_m))

    @property
    def centre_m(self) -> np.ndarray:
        return 0.5 * (self.core_from_m + self.core_to_m)


@dataclass
class Servo:
    joint: str
    kp_nm_per_rad: float
    kv_nm_s_per_rad: float
    torque_range_nm: tuple[float, float]


@dataclass
class Cylinder:
    name: str
    centre_m: np.ndarray
    radius_m: float
    half_height_m: float


@dataclass
class Heightfield:
    """A MuJoCo heightfield geom: grid vertex (r, c) stands at
    (x0 + (2c/(ncol-1) - 1)·rx, y0 + (2r/(nrow-1) - 1)·ry, z0 + ez·elevation[r, c])."""

    name: str
    pos_m: np.ndarray
    radii_m: tuple[float, float]
    elevation_scale_m: float
    base_m: float
    elevation: np.ndarray  # nrow x ncol, 0..1

    def vertices(self) -> np.ndarray:
        """Grid vertices (nrow x ncol x 3, world, m)."""
        nrow, ncol = self.elevation.shape
        x = self.pos_m[0] + (2 * np.arange(ncol) / (ncol - 1) - 1) * self.radii_m[0]
        y = self.pos_m[1] + (2 * np.arange(nrow) / (nrow - 1) - 1) * self.radii_m[1]
        xx, yy = np.meshgrid(x, y)
        return np.stack([xx, yy, self.pos_m[2] + self.elevation_scale_m * self.elevation], axis=-1)


@dataclass
class MeshObstacle:
    """A mesh obstacle (MuJoCo collides its convex hull), vertices in world coordinates."""

    name: str
    vertices_m: np.ndarray  # n x 3
    faces: np.ndarray  # m x 3

    def write_obj(self, path: Path) -> Path:
        with path.open("w") as f:
            for v in self.vertices_m:
                f.write(f"v {float(v[0])!r} {float(v[1])!r} {float(v[2])!r}\n")
            for a, b, c in self.faces:
                f.write(f"f {a + 1} {b + 1} {c + 1}\n")
        return path


@dataclass
class Model:
    timestep_secs: float
    gravity_m_per_s2: np.ndarray
    links: list[Link]
    servos: list[Servo]
    cylinders: list[Cylinder]
    heightfields: list[Heightfield]
    meshes: list[MeshObstacle]
    # Environment contact solref (time constant s, damping ratio) of floor and obstacles.
    env_time_constant_secs: float
    env_damping_ratio: float
    floor_friction: float
    obstacle_friction: float
    link_friction: float
    # Keyframe `initial`.
    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def n_joints(self) -> int:
        return len(self.links) - 1

    def link_weight_n(self, i: int) -> float:
        return self.links[i].mass_kg * float(np.linalg.norm(self.gravity_m_per_s2))


def _capsule(geom: ET.Element) -> tuple[float, np.ndarray, np.ndarray]:
    size = _floats(geom.get("size"))
    r = size[0]
    kind = geom.get("type")
    if geom.get("fromto"):
        ft = _floats(geom.get("fromto"))
        return r, np.array(ft[:3]), np.array(ft[3:])
    pos = np.array(_floats(geom.get("pos")) or [0.0, 0.0, 0.0])
    if kind == "sphere":
        return r, pos.copy(), pos.copy()
    axis = np.array(_floats(geom.get("zaxis")) or [0.0, 0.0, 1.0])
    axis = axis / np.linalg.norm(axis)
    half = size[1]
    return r, pos + half * axis, pos - half * axis


def read(path: Path) -> Model:
    root = ET.parse(path).getroot()
    option = root.find("option")
    timestep = float(option.get("timestep", "0.002"))
    gravity = np.array(_floats(option.get("gravity")) or [0.0, 0.0, -9.81])
    worlds = root.findall("worldbody")

    floor = None
    cylinders: list[Cylinder] = []
    heightfields: list[Heightfield] = []
    meshes: list[MeshObstacle] = []
    assets = {(a.tag, a.get("name")): a for a in root.findall("asset/*")}
    for geom in (g for w in worlds for g in w.findall("geom")):
        if geom.get("type") == "hfield":
            asset = assets[("hfield", geom.get("hfield"))]
            nrow, ncol = int(asset.get("nrow")), int(asset.get("ncol"))
            rx, ry, ez, base = _floats(asset.get("size"))
            elevation = np.array(_floats(asset.get("elevation"))).reshape(nrow, ncol)
            heightfields.append(Heightfield(geom.get("name"), np.array(_floats(geom.get("pos")) or [0.0, 0.0, 0.0]),
                                            (rx, ry), ez, base, elevation))
        elif geom.get("type") == "mesh":
            asset = assets[("mesh", geom.get("mesh"))]
            if geom.get("pos") or geom.get("quat") or geom.get("euler"):
                raise ValueError(f"{path}: mesh geom {geom.get('name')} is moved; only world-coordinate meshes are read")
            meshes.append(MeshObstacle(geom.get("name"), np.array(_floats(asset.get("vertex"))).reshape(-1, 3),
                                       np.array([int(v) for v in asset.get("face").split()]).reshape(-1, 3)))
        elif geom.get("type") == "plane":
            floor = geom
        elif geom.get("type") == "cylinder":
            size = _floats(geom.get("size"))
            cylinders.append(Cylinder(geom.get("name"), np.array(_floats(geom.get("pos"))), size[0], size[1]))
        elif geom.get("name", "").startswith("surface_"):
            continue
        elif geom.get("contype") != "0" or geom.get("conaffinity") != "0":
            raise ValueError(f"{path}: geom {geom.get('name')} of type {geom.get('type')} is not supported")
    if floor is None:
        raise ValueError(f"{path}: no floor plane")
    solref = _floats(floor.get("solref"))
    if len(solref) != 2 or solref[0] <= 0:
        raise ValueError(f"{path}: floor solref {floor.get('solref')} is not (time constant, damping ratio)")

    links: list[Link] = []
    body = next((b for w in worlds for b in w.findall("body")), None)
    while body is not None:
        geom = body.find("geom")
        r, a, b = _capsule(geom)
        pos = np.array(_floats(body.get("pos")) or [0.0, 0.0, 0.0])
        link = Link(body.get("name"), float(geom.get("mass")), r, a, b, pos)
        joint = body.find("joint")
        if joint is not None:
            if joint.get("type", "hinge") != "hinge":
                raise ValueError(f"{path}: joint {joint.get('name')} is not a hinge")
            if _floats(joint.get("pos")) not in ([], [0.0, 0.0, 0.0]):
                raise ValueError(f"{path}: joint {joint.get('name')} is not at its body's origin")
            link.joint_name = joint.get("name")
            link.joint_axis = np.array(_floats(joint.get("axis")))
            lo, hi = _floats(joint.get("range"))
            link.joint_range_rad = (lo, hi)
            link.joint_damping_nm_s_per_rad = float(joint.get("damping", "0"))
            link.joint_armature_kg_m2 = float(joint.get("armature", "0"))
        if body.get("quat") or (links and body.get("euler")):
            raise ValueError(f"{path}: body {body.get('name')} is rotated in its parent; not supported")
        links.append(link)
        body = body.find("body")

    servos: list[Servo] = []
    actuators = root.find("actuator")
    for act in actuators if actuators is not None else []:
        kp = float(act.get("kp", "0"))
        kv = float(act.get("kv", "0"))
        if act.tag == "position" and (kp != 0 or kv != 0):
            lo, hi = _floats(act.get("forcerange"))
            servos.append(Servo(act.get("joint"), kp, kv, (lo, hi)))
        elif act.tag in ("velocity", "intvelocity") and (kp != 0 or kv != 0):
            raise ValueError(f"{path}: {act.tag} servo {act.get('name')} has gains; only position servos are built")

    key = root.find("keyframe/key")
    n_q = 7 + len(links) - 1
    qpos = np.array(_floats(key.get("qpos"))) if key is not None else np.zeros(n_q)
    qvel = np.array(_floats(key.get("qvel"))) if key is not None and key.get("qvel") else np.zeros(n_q - 1)
    ctrl = np.array(_floats(key.get("ctrl"))) if key is not None and key.get("ctrl") else np.zeros(0)

    def first_friction(el: ET.Element | None, default: float) -> float:
        return _floats(el.get("friction"))[0] if el is not None and el.get("friction") else default

    obstacle = next((g for w in worlds for g in w.findall("geom") if g.get("type") in ("cylinder", "mesh")), None)
    obstacle_friction = first_friction(obstacle, 0.0)
    link_geom = next((g for w in worlds for g in w.findall("body/geom")), None)
    return Model(
        timestep_secs=timestep,
        gravity_m_per_s2=gravity,
        links=links,
        servos=servos,
        cylinders=cylinders,
        heightfields=heightfields,
        meshes=meshes,
        env_time_constant_secs=solref[0],
        env_damping_ratio=solref[1],
        floor_friction=first_friction(floor, 0.0),
        obstacle_friction=obstacle_friction,
        link_friction=first_friction(link_geom, 0.0),
        qpos=qpos,
        qvel=qvel,
        ctrl=ctrl,
    )

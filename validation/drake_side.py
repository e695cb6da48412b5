"""The reference: the model SimSerpent ran, rebuilt in Drake's MultibodyPlant and simulated.

How the model is built (README.md, "The reference model"):
- one rigid body per link: mass from the MJCF, the solid capsule's inertia about its centre;
- the head is a free body; link i > 0 hangs on a revolute joint at its body origin, with the
  MJCF's axis, damping and armature (Drake's reflected rotor inertia, gear ratio 1);
- collision: each link's capsule (against obstacles and other links) and, for the floor, two
  spheres of the link's radius at the ends of its capsule core: exactly the two contacts MuJoCo
  makes between a capsule and a plane;
- compliant point contact with the floor's stiffness (see `contact_stiffness`), Hunt-Crossley
  dissipation, Coulomb friction with static = dynamic coefficient, TAMSI (Drake's non-convex
  discrete solver);
- the position servos as a controller: tau = clip(kp (q_cmd - q) - kv qdot, torque range), the
  command from the scene (the gait with its ramp, or the held starting angles).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import logging

from pydrake.geometry import (
    AddContactMaterial,
    Capsule,
    CollisionFilterDeclaration,
    Convex,
    Cylinder as DrakeCylinder,
    GeometrySet,
    HalfSpace,
    ProximityProperties,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.math import SpatialForce, SpatialVelocity
from pydrake.multibody.plant import (
    AddMultibodyPlantSceneGraph,
    ContactModel,
    CoulombFriction,
    DiscreteContactApproximation,
    ExternallyAppliedSpatialForce,
    MultibodyPlant,
)
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    RevoluteJoint,
    RotationalInertia,
    SpatialInertia,
    UnitInertia,
)
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.common.value import AbstractValue

from mjcf_model import Model, quat_matrix

# Drake warns, for every plant, that half spaces take no part in deformable contact (none here).
logging.getLogger("drake").setLevel(logging.ERROR)


@dataclass
class DrakeSettings:
    # Discrete step of the TAMSI solver (s).
    time_step_secs: float = 1e-4
    # Hunt-Crossley dissipation (s/m) of the floor (and ground) contacts and of the obstacle
    # (and link-link) contacts; the suite sets both per scene from SimSerpent's measured
    # restitution (`restitution.py`).
    floor_dissipation_s_per_m: float = 50.0
    obstacle_dissipation_s_per_m: float = 50.0
    # Regularised friction: sliding speed below which a contact counts as sticking (m/s).
    stiction_tolerance_m_per_s: float = 1e-4
    # Continuous plant with an error-controlled integrator instead of the discrete TAMSI step
    # (a cross-check: the tables are then sampled every time_step_secs).
    continuous: bool = False
    integrator: str = "runge_kutta3"
    accuracy: float = 1e-4


def contact_stiffness(model: Model) -> tuple[float, float]:
    """Stiffness (N/m) of one floor contact point and of one obstacle contact, from the MJCF.

    MuJoCo's soft contact with solref (tau, zeta) drives a contact's penetration like a spring of
    natural frequency omega = 1/(tau zeta) on the contact's effective mass. A link lying on the
    floor (two contacts, one at each end of its capsule core) that sinks uniformly by x is pushed
    back by m omega^2 x: each end contact is a spring of m omega^2 / 2. A link pressed against a
    cylinder (one contact) meets m omega^2.
    """
    omega = 1.0 / (model.env_time_constant_secs * model.env_damping_ratio)
    m = model.links[0].mass_kg
    return m * omega * omega / 2.0, m * omega * omega


def _hunt_crossley_restitution(c: float, dt: float = 1e-4) -> float:
    """Restitution of a Hunt-Crossley contact f = k x (1 + d xdot) hit at speed v0, as a function
    of c = d v0 (dimensionless: x in units of v0/omega, time in units of 1/omega)."""
    y, v, t = 0.0, 1.0, 0.0
    while True:
        f = y * (1.0 + c * v)
        v -= max(0.0, f) * dt
        y += v * dt
        t += dt
        if y <= 0.0 and t > 0.01:
            return -v


def dissipation_for_restitution(target: float, impact_speed_m_per_s: float) -> float:
    """Hunt-Crossley dissipation d (s/m) whose restitution at this impact speed is `target`, for a
    mass on the contact spring alone (no gravity, no step): the first guess of the calibration in
    `restitution.py`, which then measures it on the scene's own impact test."""
    lo, hi = 1e-3, 1e3
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        if _hunt_crossley_restitution(mid) > target:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi) / impact_speed_m_per_s


@dataclass
class Ground:
    """What the links stand on in the reference where the model's ground is a heightfield: a
    plane at `plane_z_m` and spheres (centre, radius) buried in it, whose caps are the bumps. The
    scene that makes the heightfield says which surface it samples; `max_deviation_m` checks the
    heightfield's vertices against it."""

    plane_z_m: float = 0.0
    spheres: tuple = ()

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        z = np.full(np.shape(x), self.plane_z_m, dtype=float)
        for (cx, cy, cz), r in self.spheres:
            d2 = (x - cx) ** 2 + (y - cy) ** 2
            cap = cz + np.sqrt(np.maximum(r * r - d2, 0.0))
            z = np.where(d2 < r * r, np.maximum(z, cap), z)
        return z

    def max_deviation_m(self, model: Model) -> float:
        worst = 0.0
        for h in model.heightfields:
            v = h.vertices()
            worst = max(worst, float(np.abs(v[..., 2] - self.height(v[..., 0], v[..., 1])).max()))
        return worst


def _rotation_z_to(axis: np.ndarray) -> RotationMatrix:
    z = axis / np.linalg.norm(axis)
    return RotationMatrix.MakeFromOneVector(z, 2)


class Servos(LeafSystem):
    """Joint torques of the position servos (or of nothing, with zero gains)."""

    def __init__(self, plant: MultibodyPlant, model: Model, command):
        super().__init__()
        self.n = model.n_joints
        self.nq = plant.num_positions()
        self.command = command
        by_joint = {s.joint: s for s in model.servos}
        self.kp = np.zeros(self.n)
        self.kv = np.zeros(self.n)
        self.lo = np.full(self.n, -np.inf)
        self.hi = np.full(self.n, np.inf)
        for j, link in enumerate(model.links[1:]):
            s = by_joint.get(link.joint_name)
            if s is not None:
                self.kp[j], self.kv[j] = s.kp_nm_per_rad, s.kv_nm_s_per_rad
                self.lo[j], self.hi[j] = s.torque_range_nm
        self.q_start = 7
        self.v_start = plant.num_positions() + 6
        self.DeclareVectorInputPort("state", plant.num_positions() + plant.num_velocities())
        self.DeclareVectorOutputPort("torque", self.n, self._calc)

    def _calc(self, context, output):
        x = self.get_input_port(0).Eval(context)
        q = x[self.q_start : self.q_start + self.n]
        v = x[self.v_start : self.v_start + self.n]
        q_cmd = self.command(context.get_time())
        tau = self.kp * (q_cmd - q) - self.kv * v
        output.SetFromVector(np.clip(tau, self.lo, self.hi))


class PushOnHead(LeafSystem):
    """A horizontal force F(t) on link 0's centre of mass, along world +x."""

    def __init__(self, body, p_BoBcm_B: np.ndarray, force_of_time):
        super().__init__()
        self.body_index = body.index()
        self.p = p_BoBcm_B
        self.force_of_time = force_of_time
        self.DeclareAbstractOutputPort(
            "forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc
        )

    def _calc(self, context, output):
        f = ExternallyAppliedSpatialForce()
        f.body_index = self.body_index
        f.p_BoBq_B = self.p
        f.F_Bq_W = SpatialForce(np.zeros(3), np.array([self.force_of_time(context.get_time()), 0.0, 0.0]))
        output.set_value([f])


def simulate(model: Model, command, duration_secs: float, settings: DrakeSettings, push=None,
             ground: Ground | None = None, mesh_dir=None, sample_secs: float | None = None) -> dict:
    """Runs the scene; returns the tables (numpy arrays keyed like the run folder's columns).

    `command(t)` gives the joint commands (rad); `push(t)` (optional) a force (N) along +x on
    link 0's centre of mass. A model with a heightfield needs `ground` (the surface it samples,
    checked against its vertices); one with mesh obstacles a folder `mesh_dir` for their OBJ files
    (Drake's point contact collides a mesh as its convex hull, as MuJoCo does). `sample_secs`:
    one row every so many seconds (forces averaged over its steps); None: every step.
    """
    if model.heightfields:
        if ground is None:
            raise ValueError("the model has a heightfield: the reference needs the surface it samples")
        deviation = ground.max_deviation_m(model)
        if deviation > 2e-4:
            raise ValueError(f"the heightfield is {deviation * 1e3:.2f} mm off the reference's surface (> 0.2 mm)")
    ground = ground or Ground()
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0 if settings.continuous else settings.time_step_secs)
    if not settings.continuous:
        plant.set_discrete_contact_approximation(DiscreteContactApproximation.kTamsi)
    plant.set_contact_model(ContactModel.kPoint)
    plant.set_stiction_tolerance(settings.stiction_tolerance_m_per_s)
    plant.mutable_gravity_field().set_gravity_vector(model.gravity_m_per_s2)

    k_floor_point, k_obstacle = contact_stiffness(model)
    d_floor, d_obstacle = settings.floor_dissipation_s_per_m, settings.obstacle_dissipation_s_per_m

    def props(stiffness: float, mu: float, d: float) -> ProximityProperties:
        p = ProximityProperties()
        AddContactMaterial(d, stiffness, CoulombFriction(mu, mu), p)
        return p

    def floor_props() -> ProximityProperties:
        return props(2 * k_floor_point, model.floor_friction, d_floor)

    def obstacle_props() -> ProximityProperties:
        return props(2 * k_obstacle, model.obstacle_friction, d_obstacle)

    world = plant.world_body()
    floor_id = plant.RegisterCollisionGeometry(world, RigidTransform(), HalfSpace(), "floor", floor_props())
    ground_ids = [floor_id]
    if ground.plane_z_m != 0.0:
        ground_ids.append(plant.RegisterCollisionGeometry(
            world, RigidTransform([0.0, 0.0, ground.plane_z_m]), HalfSpace(), "ground_plane", floor_props()))
    for k, (centre, radius) in enumerate(ground.spheres):
        ground_ids.append(plant.RegisterCollisionGeometry(
            world, RigidTransform(np.asarray(centre, dtype=float)), Sphere(radius), f"ground_bump_{k}", floor_props()))
    obstacle_ids = []
    for c in model.cylinders:
        obstacle_ids.append(
            plant.RegisterCollisionGeometry(
                world,
                RigidTransform(c.centre_m),
                DrakeCylinder(c.radius_m, 2 * c.half_height_m),
                c.name,
                obstacle_props(),
            )
        )
    for m in model.meshes:
        if mesh_dir is None:
            raise ValueError("the model has mesh obstacles: the reference needs a folder for their OBJ files")
        obj = m.write_obj(Path(mesh_dir) / f"{m.name}.obj")
        obstacle_ids.append(plant.RegisterCollisionGeometry(world, RigidTransform(), Convex(str(obj)), m.name,
                                                            obstacle_props()))

    bodies = []
    spheres, capsules = [], []
    for i, link in enumerate(model.links):
        c = link.centre_m
        axis = link.core_to_m - link.core_from_m
        length = link.core_length_m
        unit_axis = axis / length if length > 0 else np.array([1.0, 0.0, 0.0])
        unit = UnitInertia.SolidCapsule(link.radius_m, length, unit_axis)
        I = unit.CopyToFullMatrix3() * link.mass_kg
        inertia = SpatialInertia.MakeFromCentralInertia(
            link.mass_kg, c, RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
        )
        body = plant.AddRigidBody(link.name, inertia)
        bodies.append(body)
        pose = RigidTransform(_rotation_z_to(unit_axis), c)
        capsules.append(
            plant.RegisterCollisionGeometry(
                body, pose, Capsule(link.radius_m, length), f"{link.name}_capsule", obstacle_props(),
            )
        )
        for k, end in enumerate((link.core_from_m, link.core_to_m)):
            spheres.append(
                plant.RegisterCollisionGeometry(
                    body, RigidTransform(end), Sphere(link.radius_m), f"{link.name}_end{k}", floor_props(),
                )
            )
    joints, actuators = [], []
    for i, link in enumerate(model.links[1:], start=1):
        parent = bodies[i - 1]
        frame = plant.AddFrame(FixedOffsetFrame(f"{link.name}_joint_frame", parent.body_frame(), RigidTransform(link.pos_in_parent_m)))
        joint = plant.AddJoint(
            RevoluteJoint(link.joint_name, frame, bodies[i].body_frame(), link.joint_axis, link.joint_damping_nm_s_per_rad)
        )
        lo, hi = link.joint_range_rad
        joint.set_position_limits([lo], [hi])
        joints.append(joint)
        act = plant.AddJointActuator(f"{link.joint_name}_actuator", joint)
        act.set_default_rotor_inertia(link.joint_armature_kg_m2)
        act.set_default_gear_ratio(1.0)
        actuators.append(act)
    plant.Finalize()

    # Floor contact through the end spheres only; obstacles and other links through the capsules.
    manager = scene_graph.collision_filter_manager()
    s_set, c_set = GeometrySet(spheres), GeometrySet(capsules)
    decl = CollisionFilterDeclaration()
    decl.ExcludeWithin(s_set)
    decl.ExcludeBetween(s_set, c_set)
    decl.ExcludeBetween(c_set, GeometrySet(ground_ids))
    if obstacle_ids:
        decl.ExcludeBetween(s_set, GeometrySet(obstacle_ids))
    manager.Apply(decl)

    servos = builder.AddSystem(Servos(plant, model, command))
    builder.Connect(plant.get_state_output_port(), servos.get_input_port(0))
    builder.Connect(servos.get_output_port(0), plant.get_actuation_input_port())
    if push is not None:
        p_cm = model.links[0].centre_m
        pusher = builder.AddSystem(PushOnHead(bodies[0], p_cm, push))
        builder.Connect(pusher.get_output_port(0), plant.get_applied_spatial_force_input_port())
    diagram = builder.Build()

    sim = Simulator(diagram)
    context = sim.get_mutable_context()
    pc = plant.GetMyMutableContextFromRoot(context)
    # Starting state: keyframe `initial` (head pose and velocity, joint angles).
    q = model.qpos
    R_head = quat_matrix(q[3:7])
    plant.SetFreeBodyPose(pc, bodies[0], RigidTransform(RotationMatrix(R_head), q[0:3]))
    for j, joint in enumerate(joints):
        joint.set_angle(pc, q[7 + j])
    # A snake that starts lying on the floor starts at the floor's static sink under its weight
    # (m g / (m omega^2) = g / omega^2, 10 um with the defaults), not at zero penetration, so that
    # it does not bounce in from 0.
    lowest = min(
        float((plant.EvalBodyPoseInWorld(pc, b) @ end)[2]) - link.radius_m
        for b, link in zip(bodies, model.links)
        for end in (link.core_from_m, link.core_to_m)
    )
    if abs(lowest - ground.plane_z_m) < 1e-9:
        sink = float(np.linalg.norm(model.gravity_m_per_s2)) / (2 * k_floor_point / model.links[0].mass_kg)
        plant.SetFreeBodyPose(pc, bodies[0], RigidTransform(RotationMatrix(R_head), q[0:3] - [0.0, 0.0, sink]))
    v = model.qvel
    if np.any(v[:6] != 0):
        plant.SetFreeBodySpatialVelocity(pc, bodies[0], SpatialVelocity(R_head @ v[3:6], v[0:3]))
    if settings.continuous:
        integrator = ResetIntegratorFromFlags(sim, settings.integrator, settings.time_step_secs)
        integrator.set_target_accuracy(settings.accuracy)
    sim.Initialize()

    return _record(sim, plant, pc, model, bodies, joints, set(ground_ids), set(obstacle_ids), duration_secs, settings,
                   sample_secs)


def _record(sim, plant, pc, model, bodies, joints, ground_ids, obstacle_ids, duration_secs, settings,
            sample_secs) -> dict:
    """Steps the simulator and records one row every `sample_secs` (a whole number of steps; None:
    every step): the state at the row's time, the contact forces as their mean over the steps
    since the previous row (what `figures.resample` makes of a full-rate record)."""
    n = len(bodies)
    dt = settings.time_step_secs
    steps = int(round(duration_secs / dt))
    every = 1 if sample_secs is None else int(round(sample_secs / dt))
    if every < 1 or abs(every * dt - (sample_secs or dt)) > 1e-3 * dt:
        raise ValueError(f"cannot sample every {sample_secs:g} s with Drake's step {dt:g} s (not a whole multiple)")
    body_link = {b.index(): i for i, b in enumerate(bodies)}
    rows = steps // every + 1
    t = np.zeros(rows)
    rot = np.zeros((rows, n, 3, 3))
    origin = np.zeros((rows, n, 3))
    v_origin = np.zeros((rows, n, 3))
    angvel = np.zeros((rows, n, 3))
    floor = np.zeros((rows, n, 3))
    obstacle = np.zeros((rows, n, 3))
    qdot = np.zeros((rows, len(joints)))
    qang = np.zeros((rows, len(joints)))
    p_cm = [b.default_com() for b in bodies]
    port = plant.get_contact_results_output_port()
    # Energy held in the floor's point contacts (J): ½·k·x² each, k the combined stiffness.
    elastic = np.zeros(rows)
    k_point = contact_stiffness(model)[0]
    acc = {"floor": np.zeros((n, 3)), "obstacle": np.zeros((n, 3))}

    def contacts() -> float:
        """Adds this step's contact forces to `acc`; returns the floor springs' energy."""
        energy = 0.0
        results = port.Eval(pc)
        for c in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(c)
            pair = info.point_pair()
            if pair.id_A in ground_ids or pair.id_B in ground_ids:
                target = acc["floor"]
                energy += 0.5 * k_point * pair.depth * pair.depth
            elif pair.id_A in obstacle_ids or pair.id_B in obstacle_ids:
                target = acc["obstacle"]
            else:
                continue
            f = info.contact_force()  # on body B, world frame
            b_ = body_link.get(info.bodyB_index())
            a = body_link.get(info.bodyA_index())
            if b_ is not None:
                target[b_] += f
            if a is not None:
                target[a] -= f
        return energy

    for step in range(steps + 1):
        if step > 0:
            sim.AdvanceTo(step * dt)
        energy = contacts()
        if step % every:
            continue
        k = step // every
        floor[k] = acc["floor"] / (every if step else 1)
        obstacle[k] = acc["obstacle"] / (every if step else 1)
        acc["floor"][:] = 0.0
        acc["obstacle"][:] = 0.0
        elastic[k] = energy
        t[k] = sim.get_context().get_time()
        for i, b in enumerate(bodies):
            X = plant.EvalBodyPoseInWorld(pc, b)
            V = plant.EvalBodySpatialVelocityInWorld(pc, b)
            rot[k, i] = X.rotation().matrix()
            origin[k, i] = X.translation()
            angvel[k, i] = V.rotational()
            v_origin[k, i] = V.translational()
        for j, joint in enumerate(joints):
            qang[k, j] = joint.get_angle(pc)
            qdot[k, j] = joint.get_angular_rate(pc)
    p_cm = np.array([np.asarray(p) for p in p_cm])  # links x 3, body frame
    r_cm = np.einsum("knij,nj->kni", rot, p_cm)
    pos = origin + r_cm
    vel = v_origin + np.cross(angvel, r_cm)
    return {
        "time_s": t,
        "position": pos,
        "rotation": rot,
        "velocity": vel,
        "angular_velocity": angvel,
        "floor_force": floor,
        "obstacle_force": obstacle,
        "joint_angle": qang,
        "joint_velocity": qdot,
        "floor_elastic_j": elastic,
    }

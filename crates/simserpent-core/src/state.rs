//! The plain state of one instant and the physics summaries computed from it.
//!
//! A [`Snapshot`] holds everything of thesis table 3 at one instant; the engine
//! (`simserpent::sim::World::read_snapshot`) fills it after a forward pass. Everything here is
//! plain numbers: controllers, estimators, recorders and analyses use it without the engine.
//!
//! The summaries of a run — centre of mass, heading, actuator power, peak contact force — have
//! one implementation each, here ([`centre_of_mass_m`], [`heading_xy`], [`actuator_power_w`],
//! [`peak_contact_force_n`]); [`RunTotals`] accumulates them over the recorded instants of a run,
//! [`ContactForcePeaks`] the contact forces over every step.
//! What a controller sees at one step, [`Observation`] (with its [`ContactEstimates`]), is plain
//! data too and lives here, below `control` and `estimation`, which both use it.

use serde::{Deserialize, Serialize};

/// What a controller sees at one step. All vectors are per joint (`n_joints`) or per link
/// (`n_links`); world frame unless the name says otherwise.
#[derive(Debug, Clone, Default)]
pub struct Observation {
    /// Simulated time of the state (s).
    pub time_secs: f64,
    /// Joint angles as measured by the encoders (rad; noise added when configured).
    pub joint_angle_rad: Vec<f64>,
    /// Joint velocities as measured (rad/s).
    pub joint_velocity_rad_per_s: Vec<f64>,
    /// Per joint: torque of all its actuators together (N·m, MuJoCo's `qfrc_actuator`) of the
    /// last complete model evaluation, as measured (a servo's current sensor).
    pub actuator_torque_nm: Vec<f64>,
    /// Head (link 0) frame origin, the tip of its body axis (m), exact.
    pub head_position_m: [f64; 3],
    /// Head orientation quaternion (w, x, y, z), exact.
    pub head_quat: [f64; 4],
    /// Head linear velocity (m/s), exact.
    pub head_velocity_m_per_s: [f64; 3],
    /// Per link IMU: accelerometer (proper acceleration, link frame, m/s²) as measured.
    pub imu_accel_m_per_s2: Vec<[f64; 3]>,
    /// Per link IMU: gyro (link frame, rad/s) as measured.
    pub imu_gyro_rad_per_s: Vec<[f64; 3]>,
    /// Per link IMU: orientation (w, x, y, z; the link's axes in the world frame, its
    /// `framequat` sensor) as measured; the identity for a link without that sensor.
    pub imu_quat_wxyz: Vec<[f64; 4]>,
    /// Per joint force sensor (N, in the child link's frame at the joint) as measured.
    pub joint_force_n: Vec<[f64; 3]>,
    /// Per joint torque sensor (N·m, child link frame) as measured.
    pub joint_torque_nm: Vec<[f64; 3]>,
    /// Time of the sensor sample above (s): IMU and force/torque values come from the last
    /// complete evaluation of the model, at most one step old (a sensor's latency).
    pub sensor_time_secs: f64,
    /// Contact estimates from the measured sensors (`[estimation]`, module `estimation`):
    /// per link external, floor and obstacle force, contact flag and point. Inactive (empty)
    /// when estimation is off and in the true observation.
    pub contacts: ContactEstimates,
}

impl Observation {
    /// An observation with all vectors sized for the robot.
    pub fn new(n_links: usize, n_joints: usize) -> Self {
        Self {
            joint_angle_rad: vec![0.0; n_joints],
            joint_velocity_rad_per_s: vec![0.0; n_joints],
            actuator_torque_nm: vec![0.0; n_joints],
            imu_accel_m_per_s2: vec![[0.0; 3]; n_links],
            imu_gyro_rad_per_s: vec![[0.0; 3]; n_links],
            imu_quat_wxyz: vec![[1.0, 0.0, 0.0, 0.0]; n_links],
            joint_force_n: vec![[0.0; 3]; n_joints],
            joint_torque_nm: vec![[0.0; 3]; n_joints],
            ..Self::default()
        }
    }

    /// Copies every value of `other` (same sizes) without allocating.
    pub fn copy_from(&mut self, other: &Observation) {
        self.time_secs = other.time_secs;
        self.joint_angle_rad.copy_from_slice(&other.joint_angle_rad);
        self.joint_velocity_rad_per_s.copy_from_slice(&other.joint_velocity_rad_per_s);
        self.actuator_torque_nm.copy_from_slice(&other.actuator_torque_nm);
        self.head_position_m = other.head_position_m;
        self.head_quat = other.head_quat;
        self.head_velocity_m_per_s = other.head_velocity_m_per_s;
        self.imu_accel_m_per_s2.copy_from_slice(&other.imu_accel_m_per_s2);
        self.imu_gyro_rad_per_s.copy_from_slice(&other.imu_gyro_rad_per_s);
        self.imu_quat_wxyz.copy_from_slice(&other.imu_quat_wxyz);
        self.joint_force_n.copy_from_slice(&other.joint_force_n);
        self.joint_torque_nm.copy_from_slice(&other.joint_torque_nm);
        self.sensor_time_secs = other.sensor_time_secs;
        self.contacts.copy_from(&other.contacts);
    }

    /// Number of joints.
    pub fn n_joints(&self) -> usize {
        self.joint_angle_rad.len()
    }
}

/// Per-link contact estimates of one instant, as controllers see them
/// ([`Observation::contacts`]). Empty vectors (and `active` false) when estimation is off.
/// World frame; forces on the link (N).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactEstimates {
    /// Whether an estimator filled this instant.
    pub active: bool,
    /// Total external force (floor + obstacles + other links).
    pub external_force_n: Vec<[f64; 3]>,
    /// The floor's share: normal support and friction.
    pub floor_force_n: Vec<[f64; 3]>,
    /// The rest: what obstacles push (horizontal), plus the vertical friction of a peg that holds
    /// the link up (see `estimation::motion`). Self-contacts are not part of it.
    pub obstacle_force_n: Vec<[f64; 3]>,
    /// Whether the link touches an obstacle (|obstacle force| ≥ the detection threshold).
    pub contact: Vec<bool>,
    /// Obstacle contact point: signed distance from the centre of mass along the link's axis
    /// (+x, toward the head; m), when the lateral obstacle force determines it.
    pub contact_point_along_m: Vec<Option<f64>>,
    /// The same point in the world (m).
    pub contact_point_m: Vec<Option<[f64; 3]>>,
    /// The other links' share (self-contact, link–link; horizontal, N): equal and opposite over
    /// each pair of links that the body's shape (encoders) brings into touch.
    pub self_contact_force_n: Vec<[f64; 3]>,
    /// Whether the link touches another link (the shape says so and their forces agree, see
    /// `estimation::motion`).
    pub self_contact: Vec<bool>,
    /// The floor's Coulomb coefficients the floor share used (forward, backward, lateral):
    /// `[ground]`'s, or the identified ones with `estimation.friction = "identify"`.
    pub floor_friction: [f64; 3],
}

impl ContactEstimates {
    /// The simulator's true contacts in the estimates' form, for controllers compared on the
    /// truth (`contacts = "true"`): per link the horizontal obstacle force, the contact flag (its
    /// magnitude at least `threshold_n`, the estimator's detection threshold) and the point. With
    /// `with_self` (`contacts = "true_with_self"`), the obstacle force is the obstacles' and the
    /// other links' together (what an estimator that cannot tell self-contacts apart would
    /// report if it were exact), the point the obstacles' where they push, else the other
    /// links'. The self-contact fields hold the true self-contacts either way.
    pub fn fill_from_truth(&mut self, state: &Snapshot, threshold_n: f64, with_self: bool) {
        self.active = true;
        for i in 0..self.n_links().min(state.link_obstacle_force_n.len()) {
            let (o, c) = (state.link_obstacle_force_n[i], state.link_self_contact_force_n[i]);
            let c = [c[0], c[1], 0.0];
            let f = if with_self { [o[0] + c[0], o[1] + c[1], 0.0] } else { [o[0], o[1], 0.0] };
            self.obstacle_force_n[i] = f;
            self.contact[i] = f[0].hypot(f[1]) >= threshold_n;
            let point = match state.link_obstacle_point_m[i] {
                Some(p) => Some(p),
                None if with_self => state.link_self_contact_point_m[i],
                None => None,
            };
            self.contact_point_m[i] = point;
            self.contact_point_along_m[i] = point.map(|p| state.along_link_axis_m(i, p));
            self.self_contact_force_n[i] = c;
            self.self_contact[i] = c[0].hypot(c[1]) >= threshold_n;
        }
    }

    /// The simulator's true contact forces split as the estimator splits them (the truth of the
    /// ROS 2 topic `ground_truth/contact_forces`): per link the total contact force, the floor's,
    /// the obstacles' (with their point) and the other links' (self-contact); the flags at
    /// `threshold_n`. The floor's friction coefficients are left as they are.
    pub fn fill_true_split(&mut self, state: &Snapshot, threshold_n: f64) {
        self.fill_from_truth(state, threshold_n, false);
        for i in 0..self.n_links().min(state.link_contact_force_n.len()) {
            self.external_force_n[i] = state.link_contact_force_n[i];
            self.floor_force_n[i] = state.link_floor_force_n[i];
            self.obstacle_force_n[i] = state.link_obstacle_force_n[i];
            self.self_contact_force_n[i] = state.link_self_contact_force_n[i];
        }
    }

    /// Estimates for `n_links` links (inactive until filled).
    pub fn new(n_links: usize) -> Self {
        Self {
            active: false,
            external_force_n: vec![[0.0; 3]; n_links],
            floor_force_n: vec![[0.0; 3]; n_links],
            obstacle_force_n: vec![[0.0; 3]; n_links],
            contact: vec![false; n_links],
            contact_point_along_m: vec![None; n_links],
            contact_point_m: vec![None; n_links],
            self_contact_force_n: vec![[0.0; 3]; n_links],
            self_contact: vec![false; n_links],
            floor_friction: [0.0; 3],
        }
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.external_force_n.len()
    }

    /// Copies `other` (no allocation once the sizes match).
    pub fn copy_from(&mut self, other: &ContactEstimates) {
        self.active = other.active;
        self.external_force_n.clone_from(&other.external_force_n);
        self.floor_force_n.clone_from(&other.floor_force_n);
        self.obstacle_force_n.clone_from(&other.obstacle_force_n);
        self.contact.clone_from(&other.contact);
        self.contact_point_along_m.clone_from(&other.contact_point_along_m);
        self.contact_point_m.clone_from(&other.contact_point_m);
        self.self_contact_force_n.clone_from(&other.self_contact_force_n);
        self.self_contact.clone_from(&other.self_contact);
        self.floor_friction = other.floor_friction;
    }
}

/// What a geom is, for splitting contact forces into ground reaction, obstacle and link–link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GeomClass {
    /// The floor plane (`model::names::FLOOR`) and the ground-like terrain surfaces (`terrain_*`:
    /// slope, heightfield, mesh terrain; see `model::names::is_ground`).
    Floor,
    /// An obstacle (a geom named `obstacle_*`).
    Obstacle,
    /// A geom of link `i`.
    Link(usize),
    /// Anything else (a user's scenery).
    Other,
}

/// One contact (MuJoCo's contact list), in the world frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactRow {
    /// Geom ids (names in `simserpent::sim::Index::geom_names`).
    pub geom: [usize; 2],
    /// Body ids of the two geoms.
    pub body: [usize; 2],
    /// Contact point (m), midway between the surfaces.
    pub position_m: [f64; 3],
    /// Contact normal, pointing from geom 0 to geom 1.
    pub normal: [f64; 3],
    /// Signed distance between the surfaces (m); negative = penetration.
    pub distance_m: f64,
    /// Normal force (N, ≥ 0: geom 0 pushes geom 1 along `normal`).
    pub normal_force_n: f64,
    /// Friction force along the contact frame's two tangent axes (N). Link–ground rows with
    /// `physics.floor_friction = "stick_slip"`: the share of SimSerpent's friction at this row,
    /// along the link's axis in the contact plane and across it (see `sim::Ground`).
    pub friction_force_n: [f64; 2],
    /// Total contact force on the second geom (`geom[1]`, column geom2) in the world frame (N); the first feels the opposite.
    pub force_on_geom2_n: [f64; 3],
}

impl ContactRow {
    /// Penetration depth (m, ≥ 0).
    pub fn penetration_m(&self) -> f64 {
        (-self.distance_m).max(0.0)
    }
}

/// Every quantity of thesis table 3 at one instant. Sized once; reading does not allocate
/// (except when a step has more contacts than any before it).
#[derive(Debug, Clone, Default)]
pub struct Snapshot {
    /// Simulated time (s).
    pub time_secs: f64,
    /// Per link: mass (kg).
    pub link_mass_kg: Vec<f64>,
    /// Per link: centre-of-mass position (m).
    pub link_position_m: Vec<[f64; 3]>,
    /// Per link: orientation quaternion (w, x, y, z).
    pub link_quat: Vec<[f64; 4]>,
    /// Per link: centre-of-mass linear velocity (m/s).
    pub link_velocity_m_per_s: Vec<[f64; 3]>,
    /// Per link: angular velocity (rad/s).
    pub link_angular_velocity_rad_per_s: Vec<[f64; 3]>,
    /// Per link: centre-of-mass linear acceleration (m/s², gravity not included: free fall reads g).
    pub link_acceleration_m_per_s2: Vec<[f64; 3]>,
    /// Per link: angular acceleration (rad/s²).
    pub link_angular_acceleration_rad_per_s2: Vec<[f64; 3]>,
    /// Per link: sum of all contact forces on the link (N).
    pub link_contact_force_n: Vec<[f64; 3]>,
    /// Per link: moment of those forces about the link's centre of mass (N·m).
    pub link_contact_torque_nm: Vec<[f64; 3]>,
    /// Per link: the part of `link_contact_force_n` that the floor exerts (ground reaction: normal
    /// plus friction, N), and its moment about the centre of mass (N·m).
    pub link_floor_force_n: Vec<[f64; 3]>,
    pub link_floor_torque_nm: Vec<[f64; 3]>,
    /// Per link: the part that obstacles (geoms named `obstacle_*`) exert (N), its moment about
    /// the centre of mass (N·m) and its point of application: the contact points weighted by the
    /// magnitude of each contact's force (m; `None` without obstacle contact).
    pub link_obstacle_force_n: Vec<[f64; 3]>,
    pub link_obstacle_torque_nm: Vec<[f64; 3]>,
    pub link_obstacle_point_m: Vec<Option<[f64; 3]>>,
    /// Per link: the part that other links of the robot exert (self-contact, link–link; N), and
    /// its point of application: the contact points weighted by the magnitude of each contact's
    /// force (m; `None` without self-contact). Equal and opposite over each touching pair.
    pub link_self_contact_force_n: Vec<[f64; 3]>,
    pub link_self_contact_point_m: Vec<Option<[f64; 3]>>,
    /// Per link: the part that any other geom exerts (a user's scenery that is neither floor,
    /// obstacle nor a link; N). The per-link contact force is floor + obstacle + self + other.
    pub link_other_contact_force_n: Vec<[f64; 3]>,
    /// Per link: origin of the link's frame (m): the anchor of the joint to its parent (for the
    /// generated snake; the head's front end for link 0).
    pub link_origin_m: Vec<[f64; 3]>,
    /// Floor region under each link's centre in the step that starts at this instant: 0 = plain
    /// floor, `k + 1` = `ground.surfaces[k]` (all 0 without surfaces).
    pub link_region: Vec<usize>,
    /// Per joint: angle (rad) and velocity (rad/s).
    pub joint_angle_rad: Vec<f64>,
    pub joint_velocity_rad_per_s: Vec<f64>,
    /// Per joint: torque of all its actuators together in joint space (N·m, MuJoCo's
    /// `qfrc_actuator`) at this instant.
    pub joint_actuator_torque_nm: Vec<f64>,
    /// Per joint and actuator kind (torque, position, velocity, intvelocity): actuator force (N·m).
    pub actuator_force_nm: Vec<[f64; 4]>,
    /// Per joint: internal force and torque between the links, as the joint's force/torque
    /// sensor measures it (exerted by the parent link on the child, child's frame at the joint).
    pub joint_force_n: Vec<[f64; 3]>,
    pub joint_torque_nm: Vec<[f64; 3]>,
    /// The sensor values the controller saw: true and measured.
    pub observation_true: Observation,
    pub observation_measured: Observation,
    /// Per link velocimeter (link frame, m/s), true.
    pub link_velocimeter_m_per_s: Vec<[f64; 3]>,
    /// All contacts.
    pub contacts: Vec<ContactRow>,
    /// Per link: sum of obstacle contact force magnitudes (weights of the point of application).
    obstacle_weight: Vec<f64>,
    /// Per link: the same for the self-contacts.
    self_weight: Vec<f64>,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn add_to(acc: &mut [f64; 3], v: [f64; 3], sign: f64) {
    for k in 0..3 {
        acc[k] += sign * v[k];
    }
}

impl Snapshot {
    /// Copies every value of `other` (a snapshot of the same robot) into this one; allocates only
    /// when `other` has more contacts than this one ever held (the recording thread's copies).
    pub fn copy_from(&mut self, other: &Snapshot) {
        // Destructured without `..`: a new field is a compile error here until it is copied.
        let Snapshot {
            time_secs,
            link_mass_kg,
            link_position_m,
            link_quat,
            link_velocity_m_per_s,
            link_angular_velocity_rad_per_s,
            link_acceleration_m_per_s2,
            link_angular_acceleration_rad_per_s2,
            link_contact_force_n,
            link_contact_torque_nm,
            link_floor_force_n,
            link_floor_torque_nm,
            link_obstacle_force_n,
            link_obstacle_torque_nm,
            link_obstacle_point_m,
            link_self_contact_force_n,
            link_self_contact_point_m,
            link_other_contact_force_n,
            link_origin_m,
            link_region,
            joint_angle_rad,
            joint_velocity_rad_per_s,
            joint_actuator_torque_nm,
            actuator_force_nm,
            joint_force_n,
            joint_torque_nm,
            observation_true,
            observation_measured,
            link_velocimeter_m_per_s,
            contacts,
            obstacle_weight,
            self_weight,
        } = other;
        self.time_secs = *time_secs;
        self.link_mass_kg.clone_from(link_mass_kg);
        self.link_position_m.clone_from(link_position_m);
        self.link_quat.clone_from(link_quat);
        self.link_velocity_m_per_s.clone_from(link_velocity_m_per_s);
        self.link_angular_velocity_rad_per_s.clone_from(link_angular_velocity_rad_per_s);
        self.link_acceleration_m_per_s2.clone_from(link_acceleration_m_per_s2);
        self.link_angular_acceleration_rad_per_s2.clone_from(link_angular_acceleration_rad_per_s2);
        self.link_contact_force_n.clone_from(link_contact_force_n);
        self.link_contact_torque_nm.clone_from(link_contact_torque_nm);
        self.link_floor_force_n.clone_from(link_floor_force_n);
        self.link_floor_torque_nm.clone_from(link_floor_torque_nm);
        self.link_obstacle_force_n.clone_from(link_obstacle_force_n);
        self.link_obstacle_torque_nm.clone_from(link_obstacle_torque_nm);
        self.link_obstacle_point_m.clone_from(link_obstacle_point_m);
        self.link_self_contact_force_n.clone_from(link_self_contact_force_n);
        self.link_self_contact_point_m.clone_from(link_self_contact_point_m);
        self.link_other_contact_force_n.clone_from(link_other_contact_force_n);
        self.link_origin_m.clone_from(link_origin_m);
        self.link_region.clone_from(link_region);
        self.joint_angle_rad.clone_from(joint_angle_rad);
        self.joint_velocity_rad_per_s.clone_from(joint_velocity_rad_per_s);
        self.joint_actuator_torque_nm.clone_from(joint_actuator_torque_nm);
        self.actuator_force_nm.clone_from(actuator_force_nm);
        self.joint_force_n.clone_from(joint_force_n);
        self.joint_torque_nm.clone_from(joint_torque_nm);
        self.observation_true.copy_from(observation_true);
        self.observation_measured.copy_from(observation_measured);
        self.link_velocimeter_m_per_s.clone_from(link_velocimeter_m_per_s);
        self.contacts.clone_from(contacts);
        self.obstacle_weight.clone_from(obstacle_weight);
        self.self_weight.clone_from(self_weight);
    }
    /// A snapshot sized for `n_links` links and `n_joints` joints.
    pub fn new(n_links: usize, n_joints: usize) -> Self {
        Self {
            link_mass_kg: vec![0.0; n_links],
            link_position_m: vec![[0.0; 3]; n_links],
            link_quat: vec![[1.0, 0.0, 0.0, 0.0]; n_links],
            link_velocity_m_per_s: vec![[0.0; 3]; n_links],
            link_angular_velocity_rad_per_s: vec![[0.0; 3]; n_links],
            link_acceleration_m_per_s2: vec![[0.0; 3]; n_links],
            link_angular_acceleration_rad_per_s2: vec![[0.0; 3]; n_links],
            link_contact_force_n: vec![[0.0; 3]; n_links],
            link_contact_torque_nm: vec![[0.0; 3]; n_links],
            link_floor_force_n: vec![[0.0; 3]; n_links],
            link_floor_torque_nm: vec![[0.0; 3]; n_links],
            link_obstacle_force_n: vec![[0.0; 3]; n_links],
            link_obstacle_torque_nm: vec![[0.0; 3]; n_links],
            link_obstacle_point_m: vec![None; n_links],
            link_self_contact_force_n: vec![[0.0; 3]; n_links],
            link_self_contact_point_m: vec![None; n_links],
            link_other_contact_force_n: vec![[0.0; 3]; n_links],
            link_origin_m: vec![[0.0; 3]; n_links],
            link_region: vec![0; n_links],
            joint_angle_rad: vec![0.0; n_joints],
            joint_velocity_rad_per_s: vec![0.0; n_joints],
            joint_actuator_torque_nm: vec![0.0; n_joints],
            actuator_force_nm: vec![[0.0; 4]; n_joints],
            joint_force_n: vec![[0.0; 3]; n_joints],
            joint_torque_nm: vec![[0.0; 3]; n_joints],
            observation_true: Observation::new(n_links, n_joints),
            observation_measured: Observation::new(n_links, n_joints),
            link_velocimeter_m_per_s: vec![[0.0; 3]; n_links],
            contacts: Vec::with_capacity(64),
            obstacle_weight: vec![0.0; n_links],
            self_weight: vec![0.0; n_links],
            time_secs: 0.0,
        }
    }

    /// Clears the contact list and every per-link contact sum, before the contacts of a new
    /// instant are added with [`Snapshot::add_contact`]. Needs `link_position_m` of this instant.
    pub fn begin_contacts(&mut self) {
        self.contacts.clear();
        for v in [
            &mut self.link_contact_force_n,
            &mut self.link_contact_torque_nm,
            &mut self.link_floor_force_n,
            &mut self.link_floor_torque_nm,
            &mut self.link_obstacle_force_n,
            &mut self.link_obstacle_torque_nm,
            &mut self.link_self_contact_force_n,
            &mut self.link_other_contact_force_n,
        ] {
            v.fill([0.0; 3]);
        }
        self.link_obstacle_point_m.fill(None);
        self.link_self_contact_point_m.fill(None);
        self.obstacle_weight.fill(0.0);
        self.self_weight.fill(0.0);
    }

    /// Adds one contact: to the contact list, and to the per-link sums of each side that is a
    /// link (`link[side]`), split by what the other side is (`class[1 - side]`: floor, obstacle,
    /// another link, or anything else). The force on the first geom is the opposite of `force_on_geom2_n`.
    pub fn add_contact(&mut self, row: ContactRow, link: [Option<usize>; 2], class: [Option<GeomClass>; 2]) {
        let force = row.force_on_geom2_n;
        for (side, sign) in [(0, -1.0), (1, 1.0)] {
            let Some(link) = link[side] else { continue };
            add_to(&mut self.link_contact_force_n[link], force, sign);
            let arm = sub(row.position_m, self.link_position_m[link]);
            let moment = cross(arm, force);
            add_to(&mut self.link_contact_torque_nm[link], moment, sign);
            match class[1 - side] {
                Some(GeomClass::Floor) => {
                    add_to(&mut self.link_floor_force_n[link], force, sign);
                    add_to(&mut self.link_floor_torque_nm[link], moment, sign);
                }
                Some(GeomClass::Obstacle) => {
                    add_to(&mut self.link_obstacle_force_n[link], force, sign);
                    add_to(&mut self.link_obstacle_torque_nm[link], moment, sign);
                    let w = norm(force);
                    let point = self.link_obstacle_point_m[link].get_or_insert([0.0; 3]);
                    add_to(point, row.position_m, w);
                    self.obstacle_weight[link] += w;
                }
                Some(GeomClass::Link(other)) if other != link => {
                    add_to(&mut self.link_self_contact_force_n[link], force, sign);
                    let w = norm(force);
                    let point = self.link_self_contact_point_m[link].get_or_insert([0.0; 3]);
                    add_to(point, row.position_m, w);
                    self.self_weight[link] += w;
                }
                _ => add_to(&mut self.link_other_contact_force_n[link], force, sign),
            }
        }
        self.contacts.push(row);
    }

    /// Ends the contacts of this instant: the obstacle and self-contact points of application
    /// become weighted means (a contact without force has no point of application).
    pub fn end_contacts(&mut self) {
        let obstacles = self.link_obstacle_point_m.iter_mut().zip(&self.obstacle_weight);
        let selves = self.link_self_contact_point_m.iter_mut().zip(&self.self_weight);
        for (point, &w) in obstacles.chain(selves) {
            match point {
                Some(p) if w > 0.0 => p.iter_mut().for_each(|x| *x /= w),
                _ => *point = None,
            }
        }
    }

    /// Largest contact normal force in this snapshot (N).
    pub fn peak_contact_force_n(&self) -> f64 {
        peak_contact_force_n(self.contacts.iter().map(|c| c.normal_force_n))
    }

    /// Largest penetration in this snapshot (m, ≥ 0).
    pub fn max_penetration_m(&self) -> f64 {
        self.contacts.iter().map(ContactRow::penetration_m).fold(0.0, f64::max)
    }

    /// Mass-weighted centre of the links (m).
    /// Signed distance (m) of `point_m` from link `i`'s centre of mass along the link's axis
    /// (+ toward the head): where along the link a contact acts.
    pub fn along_link_axis_m(&self, i: usize, point_m: [f64; 3]) -> f64 {
        let (axis, centre) = (x_axis(self.link_quat[i]), self.link_position_m[i]);
        (0..3).map(|k| (point_m[k] - centre[k]) * axis[k]).sum()
    }

    pub fn centre_of_mass_m(&self) -> [f64; 3] {
        centre_of_mass_m(self.link_mass_kg.iter().copied().zip(self.link_position_m.iter().copied()))
    }

    /// Σ over joints of |τ·q̇| at this instant (W).
    pub fn actuator_power_w(&self) -> f64 {
        actuator_power_w(
            self.joint_actuator_torque_nm.iter().copied().zip(self.joint_velocity_rad_per_s.iter().copied()),
        )
    }

    /// The way the head faces in the xy-plane (see [`heading_xy`]).
    pub fn head_heading_xy(&self) -> [f64; 2] {
        self.link_quat.first().map_or([1.0, 0.0], |q| heading_xy(*q))
    }
}

/// Mass-weighted centre of `(mass_kg, position_m)` pairs (m); the origin if the mass is zero.
pub fn centre_of_mass_m(links: impl IntoIterator<Item = (f64, [f64; 3])>) -> [f64; 3] {
    let mut c = [0.0; 3];
    let mut total = 0.0;
    for (mass_kg, p) in links {
        for k in 0..3 {
            c[k] += mass_kg * p[k];
        }
        total += mass_kg;
    }
    if total > 0.0 { c.map(|x| x / total) } else { c }
}

/// Unit vector in the xy-plane along a body's +x axis, for the orientation quaternion
/// `(w, x, y, z)`; `[1, 0]` when the axis is vertical.
pub fn heading_xy([w, x, y, z]: [f64; 4]) -> [f64; 2] {
    let (hx, hy) = (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z));
    let norm = hx.hypot(hy);
    if norm > 1e-9 { [hx / norm, hy / norm] } else { [1.0, 0.0] }
}

/// The body's +x axis in the world frame (the first column of the rotation matrix) for the
/// unit orientation quaternion `(w, x, y, z)`; for the snake's links, the link's axis toward the head.
pub fn x_axis([w, x, y, z]: [f64; 4]) -> [f64; 3] {
    [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)]
}

/// Yaw angle (rad, in (−π, π]) of the orientation quaternion `(w, x, y, z)`: the first angle of
/// the intrinsic z-y′-x″ (yaw-pitch-roll) Euler angles, which is the direction of the body's
/// +x axis in the xy-plane measured from world +x, counter-clockwise seen from above. For the
/// snake's links (+x points towards the head) it is the heading of the link. Undefined (numerically any value) when
/// the axis is vertical (no heading).
pub fn yaw_rad([w, x, y, z]: [f64; 4]) -> f64 {
    (2.0 * (x * y + w * z)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// Σ over joints of |τ·q̇| (W) for `(joint-space actuator torque N·m, joint velocity rad/s)`
/// pairs: the rate at which the actuators do work, counting braking as work too.
pub fn actuator_power_w(joints: impl IntoIterator<Item = (f64, f64)>) -> f64 {
    joints.into_iter().map(|(torque_nm, velocity)| (torque_nm * velocity).abs()).sum()
}

/// Largest of the contact normal forces (N, ≥ 0; 0 without contacts).
pub fn peak_contact_force_n(normal_forces_n: impl IntoIterator<Item = f64>) -> f64 {
    normal_forces_n.into_iter().map(f64::abs).fold(0.0, f64::max)
}

/// The window over which the run summary averages each link's contact force: 10 ms (rounded to
/// whole steps, see [`ContactForcePeaks::window_secs`]). Long against a step, short against a gait
/// cycle: an impact's whole impulse falls in it, a steady load keeps its value.
pub const CONTACT_FORCE_WINDOW_SECS: f64 = 0.01;

/// A run's peak contact forces, from every physics step (not only the recorded ones).
///
/// - **Windowed peak** (`peak_windowed_n`, the run summary's `peak_contact_force_10ms_n`): per
///   link, the vector sum of the normal forces of all its contacts (floor, obstacles, other links,
///   scenery) times the step, summed over the last `window_steps` steps — the normal impulse the
///   link received in that window — divided by the window's length; the largest magnitude over
///   links and windows. A force averaged over a fixed time: as dt → 0 it converges to
///   max |∫_window F dt| / window, and an impact that ends inside the window counts with its whole
///   impulse (m·Δv, whatever the contact's stiffness). Before the run's first step the force is 0.
///   The forces are those at each step's start (as a recorded row shows them): with the Euler and
///   implicit integrators exactly the forces the step applies (the window's impulse is the
///   momentum change), with RK4 the first of its four evaluations, a sample whose error is first
///   order in the step (on a 2-ms impact +20 % at 1 ms, +11 % at 0.5 ms, +6 % at 0.25 ms).
/// - **Per-step peak** (`peak_step_n`): the largest single contact's normal force at any step.
///   A sample of the sharpest transient; it depends on the timestep and the contact stiffness
///   and does not converge as dt → 0 under a stiff impact.
///
/// [`ContactForcePeaks::add_step`] takes the forces that act during one step; it does not
/// allocate.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactForcePeaks {
    n_links: usize,
    dt_secs: f64,
    window_steps: usize,
    /// The last `window_steps` steps' forces per link (slot-major), a ring from `next`.
    ring: Vec<[f64; 3]>,
    next: usize,
    /// Largest windowed force (N), on which link, and when its window ended (s).
    pub peak_windowed_n: f64,
    pub peak_windowed_link: Option<usize>,
    pub peak_windowed_end_secs: f64,
    /// Largest single-contact normal force at any step (N).
    pub peak_step_n: f64,
}

impl ContactForcePeaks {
    /// Peaks of `n_links` links stepped with `dt_secs`, over [`CONTACT_FORCE_WINDOW_SECS`].
    pub fn new(n_links: usize, dt_secs: f64) -> Self {
        Self::with_window(n_links, dt_secs, CONTACT_FORCE_WINDOW_SECS)
    }

    /// Peaks over a window of `window_secs`, rounded to whole steps (at least one).
    pub fn with_window(n_links: usize, dt_secs: f64, window_secs: f64) -> Self {
        let window_steps = if dt_secs > 0.0 { (window_secs / dt_secs).round().max(1.0) as usize } else { 1 };
        Self {
            n_links,
            dt_secs,
            window_steps,
            ring: vec![[0.0; 3]; window_steps * n_links],
            next: 0,
            peak_windowed_n: 0.0,
            peak_windowed_link: None,
            peak_windowed_end_secs: 0.0,
            peak_step_n: 0.0,
        }
    }

    /// The window's length: whole steps nearest [`CONTACT_FORCE_WINDOW_SECS`] (s).
    pub fn window_secs(&self) -> f64 {
        self.window_steps as f64 * self.dt_secs
    }

    /// Back to no steps.
    pub fn clear(&mut self) {
        self.ring.fill([0.0; 3]);
        self.next = 0;
        self.peak_windowed_n = 0.0;
        self.peak_windowed_link = None;
        self.peak_windowed_end_secs = 0.0;
        self.peak_step_n = 0.0;
    }

    /// Adds one step that ends at `end_secs`: per link the vector sum of its contacts' normal
    /// forces acting during the step (N, world), and the largest single contact normal force.
    pub fn add_step(&mut self, end_secs: f64, link_normal_force_n: &[[f64; 3]], largest_contact_n: f64) {
        let n = self.n_links;
        let slot = self.next * n;
        for (dst, src) in self.ring[slot..slot + n].iter_mut().zip(link_normal_force_n) {
            *dst = *src;
        }
        self.next = (self.next + 1) % self.window_steps;
        // Summed afresh over the window (no running sum: no rounding residue after a transient).
        let scale = 1.0 / self.window_steps as f64;
        for link in 0..n {
            let mut sum = [0.0; 3];
            for s in 0..self.window_steps {
                add_to(&mut sum, self.ring[s * n + link], 1.0);
            }
            let mean_n = norm(sum) * scale;
            if mean_n > self.peak_windowed_n {
                self.peak_windowed_n = mean_n;
                self.peak_windowed_link = Some(link);
                self.peak_windowed_end_secs = end_secs;
            }
        }
        self.peak_step_n = self.peak_step_n.max(largest_contact_n.abs());
    }
}

/// What a run's summary adds up over its recorded instants: displacement and heading of the
/// centre of mass, largest penetration and actuator energy (the peak contact forces come from every
/// step: [`ContactForcePeaks`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunTotals {
    start_com_m: Option<[f64; 3]>,
    start_heading_xy: Option<[f64; 2]>,
    end_com_m: [f64; 3],
    /// Largest penetration seen (m).
    pub max_penetration_m: f64,
    /// ∫ Σ_joints |τ·q̇| dt over the recorded instants, each held until the next one (J).
    pub actuator_energy_j: f64,
    /// Time during which some link touched an obstacle (a non-zero obstacle force), from the
    /// recorded instants, each held until the next one (s).
    pub obstacle_contact_secs: f64,
}

/// The displacement part of a run's summary.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Displacement {
    /// Horizontal displacement of the centre of mass from the first to the last instant (m).
    pub distance_m: f64,
    /// Its direction in the xy-plane (degrees from +x).
    pub heading_deg: f64,
    /// The displacement projected on the direction the head faced at the first instant (m).
    pub forward_m: f64,
}

impl RunTotals {
    /// Adds a recorded instant whose values hold for `held_steps` steps of `dt_secs` (for the
    /// energy).
    pub fn add(&mut self, s: &Snapshot, dt_secs: f64, held_steps: u64) {
        self.max_penetration_m = self.max_penetration_m.max(s.max_penetration_m());
        self.end_com_m = s.centre_of_mass_m();
        self.start_com_m.get_or_insert(self.end_com_m);
        self.start_heading_xy.get_or_insert_with(|| s.head_heading_xy());
        self.actuator_energy_j += s.actuator_power_w() * dt_secs * held_steps as f64;
        if s.link_obstacle_force_n.iter().any(|f| f.iter().any(|x| *x != 0.0)) {
            self.obstacle_contact_secs += dt_secs * held_steps as f64;
        }
    }

    /// Displacement from the first to the last instant added.
    pub fn displacement(&self) -> Displacement {
        let start = self.start_com_m.unwrap_or(self.end_com_m);
        let (dx, dy) = (self.end_com_m[0] - start[0], self.end_com_m[1] - start[1]);
        let heading = self.start_heading_xy.unwrap_or([1.0, 0.0]);
        Displacement {
            distance_m: dx.hypot(dy),
            heading_deg: dy.atan2(dx).to_degrees(),
            forward_m: dx * heading[0] + dy * heading[1],
        }
    }
}

/// How well the joints followed their commanded angles: what [`JointTracking`] reports, added up
/// one instant at a time (no allocation after [`TrackingTotals::new`]).
///
/// Only instants at or after `from_secs` count (the end of the gait's ramp-in, when the command
/// has its full amplitude); when the run ends before that, every instant counts.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackingTotals {
    from_secs: f64,
    /// Per joint: [Σ error², max |error|, min ref, max ref, min actual, max actual] after `from_secs`
    /// (index 0) and over the whole run (index 1).
    acc: [Vec<[f64; 6]>; 2],
    count: [u64; 2],
}

/// One joint's tracking of its commanded angle over a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointTracking {
    /// The joint's name.
    pub joint: String,
    /// Half the peak-to-peak range of the commanded angle (rad): the amplitude of a wave.
    pub command_amplitude_rad: f64,
    /// Half the peak-to-peak range of the joint's actual angle, in % of the command's.
    pub reached_amplitude_percent: f64,
    /// Root mean square of (actual − commanded angle) (rad), and in % of the command amplitude.
    pub rms_error_rad: f64,
    pub rms_error_percent: f64,
    /// Largest |actual − commanded angle| (rad), and in % of the command amplitude.
    pub max_error_rad: f64,
    pub max_error_percent: f64,
}

/// A joint "tracks" its command when it reaches 90–110 % of the commanded amplitude and its RMS
/// error stays within 10 % of that amplitude (for a sine, 10 % RMS is a phase lag of about 8°
/// at full amplitude). See [`JointTracking::tracks`].
pub const TRACKING_AMPLITUDE_PERCENT: [f64; 2] = [90.0, 110.0];
/// See [`TRACKING_AMPLITUDE_PERCENT`].
pub const TRACKING_RMS_ERROR_PERCENT: f64 = 10.0;

impl JointTracking {
    /// Whether the joint followed its command well enough (see [`TRACKING_AMPLITUDE_PERCENT`]).
    pub fn tracks(&self) -> bool {
        let [lo, hi] = TRACKING_AMPLITUDE_PERCENT;
        (lo..=hi).contains(&self.reached_amplitude_percent) && self.rms_error_percent <= TRACKING_RMS_ERROR_PERCENT
    }
}

impl TrackingTotals {
    /// Totals for `n_joints` joints, counting instants from `from_secs` on.
    pub fn new(n_joints: usize, from_secs: f64) -> Self {
        let start = [0.0, 0.0, f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
        Self { from_secs, acc: [vec![start; n_joints], vec![start; n_joints]], count: [0; 2] }
    }

    /// Adds one instant: the commanded and the actual angle of every joint (rad).
    pub fn add(&mut self, time_secs: f64, command_rad: &[f64], actual_rad: &[f64]) {
        let parts: &[usize] = if time_secs >= self.from_secs { &[0, 1] } else { &[1] };
        for &p in parts {
            self.count[p] += 1;
            for ((a, &c), &x) in self.acc[p].iter_mut().zip(command_rad).zip(actual_rad) {
                let e = x - c;
                a[0] += e * e;
                a[1] = a[1].max(e.abs());
                a[2] = a[2].min(c);
                a[3] = a[3].max(c);
                a[4] = a[4].min(x);
                a[5] = a[5].max(x);
            }
        }
    }

    /// The report per joint (named by `joint_names`), or nothing when no instant was added or no
    /// joint was commanded to move (a command amplitude of zero has no percentages).
    pub fn report(&self, joint_names: &[String]) -> Option<Vec<JointTracking>> {
        let p = if self.count[0] > 0 { 0 } else { 1 };
        let n = self.count[p];
        if n == 0 || self.acc[p].iter().all(|a| a[3] - a[2] <= 0.0) {
            return None;
        }
        let percent = |x: f64, of: f64| if of > 0.0 { 100.0 * x / of } else { 0.0 };
        Some(
            self.acc[p]
                .iter()
                .zip(joint_names)
                .map(|(a, name)| {
                    let amplitude = 0.5 * (a[3] - a[2]);
                    let rms = (a[0] / n as f64).sqrt();
                    JointTracking {
                        joint: name.clone(),
                        command_amplitude_rad: amplitude,
                        reached_amplitude_percent: percent(0.5 * (a[5] - a[4]), amplitude),
                        rms_error_rad: rms,
                        rms_error_percent: percent(rms, amplitude),
                        max_error_rad: a[1],
                        max_error_percent: percent(a[1], amplitude),
                    }
                })
                .collect(),
        )
    }
}

/// The point of the friction ellipse (x/a)² + (y/b)² ≤ 1 nearest to (x, y) (Euclidean): (x, y) itself
/// when inside. Degenerate axes (a or b = 0) give a segment or the origin. One implementation
/// for SimSerpent's own friction law (`sim::ground`) and the estimator's floor share.
pub fn project_to_ellipse(x: f64, y: f64, a: f64, b: f64) -> (f64, f64) {
    if a <= 0.0 && b <= 0.0 {
        return (0.0, 0.0);
    }
    if a <= 0.0 {
        return (0.0, y.clamp(-b, b));
    }
    if b <= 0.0 {
        return (x.clamp(-a, a), 0.0);
    }
    if (x / a).powi(2) + (y / b).powi(2) <= 1.0 {
        return (x, y);
    }
    // Nearest point: (a² x / (a² + t), b² y / (b² + t)) with t ≥ 0 the root of
    // f(t) = (a x / (a² + t))² + (b y / (b² + t))² − 1, convex and decreasing: Newton from
    // below the root climbs to it without overshooting. The start is the largest of three
    // lower bounds of the root: each term of f + 1 is at most 1 there (t ≥ a|x| − a²,
    // t ≥ b|y| − b²), and f + 1 ≥ (a²x² + b²y²) / (max(a², b²) + t)²; from it Newton takes about
    // 3 iterations where it took about 16 from 0 (a force far outside a flat ellipse).
    let (a2, b2) = (a * a, b * b);
    let (ax, by) = (a * x.abs(), b * y.abs());
    let mut t = (ax - a2).max(by - b2).max((ax * ax + by * by).sqrt() - a2.max(b2)).max(0.0);
    for _ in 0..50 {
        let (p, q) = (a * x / (a2 + t), b * y / (b2 + t));
        let f = p * p + q * q - 1.0;
        if f <= 1e-12 {
            break;
        }
        let df = -2.0 * (p * p / (a2 + t) + q * q / (b2 + t));
        t -= f / df;
    }
    let (px, py) = (a2 * x / (a2 + t), b2 * y / (b2 + t));
    // Exactly onto the boundary (the Newton root leaves it a hair outside at most).
    let s = ((px / a).powi(2) + (py / b).powi(2)).sqrt();
    if s > 1.0 { (px / s, py / s) } else { (px, py) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Forces far outside a flat ellipse (sliding on the anisotropic floor, μ 0.1 and 1): the
    /// projection lies on the ellipse and the residual along its normal (the nearest point).
    #[test]
    fn projection_far_outside_a_flat_ellipse_is_the_nearest_point() {
        let (a, b) = (0.1, 1.0);
        for (x, y) in [(1e3, 1.0), (50.0, -30.0), (-0.2, 400.0), (7.0, 0.0), (0.0, -9.0), (-1e4, -1e4)] {
            let (px, py) = project_to_ellipse(x, y, a, b);
            let on = (px / a).powi(2) + (py / b).powi(2);
            assert!((on - 1.0).abs() < 1e-12, "({x}, {y}): (x/a)² + (y/b)² = {on}");
            let (nx, ny) = (px / (a * a), py / (b * b));
            let cross = (x - px) * ny - (y - py) * nx;
            assert!(cross.abs() < 1e-9 * (x - px).hypot(y - py) * nx.hypot(ny), "({x}, {y}): residual off the normal");
            assert!((x - px) * nx + (y - py) * ny > 0.0, "({x}, {y}): residual points inward");
        }
    }

    #[test]
    fn centre_of_mass_weights_by_mass() {
        let c = centre_of_mass_m([(1.0, [0.0, 0.0, 0.0]), (3.0, [4.0, 8.0, -4.0])]);
        assert_eq!(c, [3.0, 6.0, -3.0]);
        assert_eq!(centre_of_mass_m([(0.0, [1.0, 1.0, 1.0])]), [0.0; 3]);
    }

    #[test]
    fn heading_of_a_yaw_rotation() {
        let yaw = 30f64.to_radians();
        let h = heading_xy([(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()]);
        assert!((h[0] - yaw.cos()).abs() < 1e-12 && (h[1] - yaw.sin()).abs() < 1e-12);
        // Pointing straight up: no heading, +x by convention.
        let pitch = -90f64.to_radians();
        assert_eq!(heading_xy([(pitch / 2.0).cos(), 0.0, (pitch / 2.0).sin(), 0.0]), [1.0, 0.0]);
    }

    #[test]
    fn yaw_of_a_rotation_is_its_heading_angle() {
        let q_of = |axis: [f64; 3], angle: f64| {
            let s = (angle / 2.0).sin();
            [(angle / 2.0).cos(), axis[0] * s, axis[1] * s, axis[2] * s]
        };
        for deg in [-179.0, -90.0, -30.0, 0.0, 45.0, 135.0, 180.0] {
            let yaw = f64::to_radians(deg);
            assert!((yaw_rad(q_of([0.0, 0.0, 1.0], yaw)) - yaw).abs() < 1e-12, "{deg}°");
        }
        // A roll about the body's own +x axis after a yaw keeps the yaw; a pitch of 20° too.
        let mul = |a: [f64; 4], b: [f64; 4]| {
            [
                a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
            ]
        };
        let yawed = q_of([0.0, 0.0, 1.0], 1.0);
        let q = mul(mul(yawed, q_of([0.0, 1.0, 0.0], 0.35)), q_of([1.0, 0.0, 0.0], 0.7));
        assert!((yaw_rad(q) - 1.0).abs() < 1e-12);
        let h = heading_xy(q);
        assert!((yaw_rad(q) - h[1].atan2(h[0])).abs() < 1e-12);
    }

    #[test]
    fn power_counts_braking_and_peak_ignores_sign() {
        assert_eq!(actuator_power_w([(2.0, 3.0), (-1.0, 4.0)]), 10.0);
        assert_eq!(peak_contact_force_n([1.0, -5.0, 3.0]), 5.0);
        assert_eq!(peak_contact_force_n(std::iter::empty()), 0.0);
    }

    #[test]
    fn windowed_peak_is_the_impulse_over_the_window() {
        // An impulse of 0.5 N·s on link 1, delivered in one step of 1 ms or spread over four:
        // either way 0.5 N·s / 10 ms = 50 N averaged over the window; the per-step peak differs.
        for spread in [1usize, 4] {
            let mut p = ContactForcePeaks::new(2, 0.001);
            assert!((p.window_secs() - 0.01).abs() < 1e-15);
            let f = 0.5 / (0.001 * spread as f64);
            for k in 0..30 {
                let on = (5..5 + spread).contains(&k);
                p.add_step(0.001 * (k + 1) as f64, &[[0.0, 0.0, 1.0], [0.0, 0.0, if on { f } else { 0.0 }]], f);
            }
            assert!((p.peak_windowed_n - 50.0).abs() < 1e-9, "{spread}: {}", p.peak_windowed_n);
            assert_eq!(p.peak_windowed_link, Some(1));
            assert_eq!(p.peak_step_n, f);
            // The window first holds the whole impulse at the end of its last step.
            assert!((p.peak_windowed_end_secs - 0.001 * (5 + spread) as f64).abs() < 1e-12);
        }
        // Opposite forces within one window cancel (a vector impulse); a steady 1 N stays 1 N.
        let mut p = ContactForcePeaks::new(1, 0.002);
        for k in 0..20 {
            p.add_step(0.0, &[[if k % 2 == 0 { 7.0 } else { -7.0 }, 0.0, 1.0]], 7.0);
        }
        // Window of 5 steps: at most one unpaired 7 N step: |(7, 0, 5)| / 5.
        assert!((p.peak_windowed_n - (49.0f64 + 25.0).sqrt() / 5.0).abs() < 1e-12);
        p.clear();
        assert_eq!((p.peak_windowed_n, p.peak_step_n, p.peak_windowed_link), (0.0, 0.0, None));
        // A window that is not a whole number of steps: the nearest whole number.
        assert!((ContactForcePeaks::new(1, 0.003).window_secs() - 0.009).abs() < 1e-15);
    }

    #[test]
    fn contacts_split_by_the_other_side() {
        let mut s = Snapshot::new(2, 1);
        s.link_position_m = vec![[0.0; 3], [1.0, 0.0, 0.0]];
        s.begin_contacts();
        // Floor (geom 0) pushes link 0 (geom 1) up with 2 N at (0.5, 0, 0).
        let row =
            ContactRow { position_m: [0.5, 0.0, 0.0], force_on_geom2_n: [0.0, 0.0, 2.0], ..ContactRow::default() };
        s.add_contact(row, [None, Some(0)], [Some(GeomClass::Floor), Some(GeomClass::Link(0))]);
        // Link 1 (geom 0) against an obstacle (geom 1): the link feels the opposite force.
        let row =
            ContactRow { position_m: [1.0, 1.0, 0.0], force_on_geom2_n: [0.0, 3.0, 0.0], ..ContactRow::default() };
        s.add_contact(row, [Some(1), None], [Some(GeomClass::Link(1)), Some(GeomClass::Obstacle)]);
        // Link 0 (geom 0) pushes link 1 (geom 1) with 4 N along +x at (0.6, 0, 0): a self-contact,
        // equal and opposite on the pair, in neither the floor's nor the obstacles' share; a
        // scenery geom (class Other) pushes link 0 with 1 N.
        let row =
            ContactRow { position_m: [0.6, 0.0, 0.0], force_on_geom2_n: [4.0, 0.0, 0.0], ..ContactRow::default() };
        s.add_contact(row, [Some(0), Some(1)], [Some(GeomClass::Link(0)), Some(GeomClass::Link(1))]);
        let row = ContactRow { force_on_geom2_n: [0.0, 1.0, 0.0], ..ContactRow::default() };
        s.add_contact(row, [None, Some(0)], [Some(GeomClass::Other), Some(GeomClass::Link(0))]);
        s.end_contacts();
        assert_eq!(s.link_self_contact_force_n[0], [-4.0, 0.0, 0.0]);
        assert_eq!(s.link_self_contact_force_n[1], [4.0, 0.0, 0.0]);
        assert_eq!(s.link_self_contact_point_m[1], Some([0.6, 0.0, 0.0]));
        assert_eq!(s.link_other_contact_force_n[0], [0.0, 1.0, 0.0]);
        assert_eq!(s.link_other_contact_force_n[1], [0.0; 3]);
        assert_eq!(s.link_obstacle_force_n[0], [0.0; 3]);
        for i in 0..2 {
            let parts = [
                s.link_floor_force_n[i],
                s.link_obstacle_force_n[i],
                s.link_self_contact_force_n[i],
                s.link_other_contact_force_n[i],
            ];
            let sum = parts.iter().fold([0.0; 3], |acc, p| [acc[0] + p[0], acc[1] + p[1], acc[2] + p[2]]);
            assert_eq!(sum, s.link_contact_force_n[i], "link {i}: the parts add up to the total");
        }
        assert_eq!(s.link_floor_force_n[0], [0.0, 0.0, 2.0]);
        assert_eq!(s.link_floor_torque_nm[0], [0.0, -1.0, 0.0]);
        assert_eq!(s.link_obstacle_force_n[1], [0.0, -3.0, 0.0]);
        assert_eq!(s.link_obstacle_point_m[1], Some([1.0, 1.0, 0.0]));
        assert_eq!(s.link_obstacle_point_m[0], None);
        assert_eq!(s.contacts.len(), 4);
        // A new instant starts from zero.
        s.begin_contacts();
        assert_eq!(s.link_floor_force_n[0], [0.0; 3]);
        assert_eq!((s.link_self_contact_force_n[1], s.link_self_contact_point_m[1]), ([0.0; 3], None));
        assert!(s.contacts.is_empty());
    }

    #[test]
    fn true_contacts_with_and_without_the_self_contacts() {
        // Link 0 pushed by a peg (2 N along +y at its centre) and by link 1 (3 N along −x);
        // link 1 only by link 0.
        let mut s = Snapshot::new(2, 1);
        s.link_position_m = vec![[0.0; 3], [-0.2, 0.0, 0.0]];
        s.begin_contacts();
        let row = ContactRow { force_on_geom2_n: [0.0, 2.0, 0.0], ..ContactRow::default() };
        s.add_contact(row, [None, Some(0)], [Some(GeomClass::Obstacle), Some(GeomClass::Link(0))]);
        let row =
            ContactRow { position_m: [-0.1, 0.0, 0.0], force_on_geom2_n: [-3.0, 0.0, 0.0], ..ContactRow::default() };
        s.add_contact(row, [Some(1), Some(0)], [Some(GeomClass::Link(1)), Some(GeomClass::Link(0))]);
        s.end_contacts();
        let mut e = ContactEstimates::new(2);
        e.fill_from_truth(&s, 0.8, false);
        assert_eq!(e.obstacle_force_n, vec![[0.0, 2.0, 0.0], [0.0; 3]]);
        assert_eq!(e.contact, vec![true, false]);
        assert_eq!(e.self_contact_force_n, vec![[-3.0, 0.0, 0.0], [3.0, 0.0, 0.0]]);
        assert_eq!(e.self_contact, vec![true, true]);
        e.fill_from_truth(&s, 0.8, true);
        assert_eq!(e.obstacle_force_n, vec![[-3.0, 2.0, 0.0], [3.0, 0.0, 0.0]]);
        assert_eq!(e.contact, vec![true, true]);
        // Link 0 keeps the peg's point, link 1 gets the other link's.
        assert_eq!(e.contact_point_m[0], Some([0.0; 3]));
        let p = e.contact_point_m[1].expect("the other link's point");
        assert!((p[0] + 0.1).abs() < 1e-12 && p[1] == 0.0 && p[2] == 0.0, "{p:?}");
        let mut t = ContactEstimates::new(2);
        t.fill_true_split(&s, 0.8);
        assert_eq!(t.external_force_n, s.link_contact_force_n);
        assert_eq!((t.obstacle_force_n[1], t.self_contact_force_n[1]), ([0.0; 3], [3.0, 0.0, 0.0]));
    }

    #[test]
    fn tracking_of_a_lagging_smaller_sine() {
        // Command A·sin(ωt); the joint answers 0.77·A·sin(ωt − 30°) (a servo that cannot keep up).
        let (a, w, lag) = (0.2, std::f64::consts::TAU * 0.5, 30f64.to_radians());
        let mut t = TrackingTotals::new(2, 1.0);
        let n = 200_000;
        for k in 0..=n {
            let time = 1.0 + 4.0 * k as f64 / n as f64; // four whole periods after the ramp
            let c = a * (w * time).sin();
            t.add(time, &[c, c], &[0.77 * a * (w * time - lag).sin(), c]);
        }
        t.add(0.5, &[5.0, 5.0], &[0.0, 0.0]); // before `from_secs`: not counted
        let r = t.report(&["joint_01".into(), "joint_02".into()]).expect("a report");
        assert!((r[0].command_amplitude_rad - a).abs() < 1e-6);
        assert!((r[0].reached_amplitude_percent - 77.0).abs() < 1e-3);
        // |0.77 e^{-i lag} − 1| · A / √2 is the RMS of the difference of the two sines.
        let gap = ((0.77 * lag.cos() - 1.0).powi(2) + (0.77 * lag.sin()).powi(2)).sqrt();
        assert!((r[0].rms_error_rad - gap * a / 2f64.sqrt()).abs() < 1e-5, "{:?}", r[0]);
        assert!((r[0].max_error_rad - gap * a).abs() < 1e-5);
        assert!((r[0].max_error_percent - 100.0 * gap).abs() < 1e-2);
        assert!(!r[0].tracks());
        assert_eq!((r[1].rms_error_rad, r[1].max_error_rad, r[1].reached_amplitude_percent), (0.0, 0.0, 100.0));
        assert!(r[1].tracks());
        // Nothing commanded: no report.
        let mut still = TrackingTotals::new(1, 0.0);
        still.add(0.0, &[0.0], &[0.01]);
        assert!(still.report(&["joint_01".into()]).is_none());
    }

    #[test]
    fn totals_of_a_straight_run() {
        let mut s = Snapshot::new(1, 1);
        s.link_mass_kg[0] = 1.0;
        s.joint_actuator_torque_nm[0] = 2.0;
        s.joint_velocity_rad_per_s[0] = -0.5;
        let mut t = RunTotals::default();
        t.add(&s, 0.1, 1);
        s.link_position_m[0] = [3.0, 4.0, 0.0];
        t.add(&s, 0.1, 1);
        let d = t.displacement();
        assert_eq!(d.distance_m, 5.0);
        assert_eq!(d.forward_m, 3.0);
        assert!((d.heading_deg - 53.130_102_354_155_98).abs() < 1e-9);
        assert!((t.actuator_energy_j - 0.2).abs() < 1e-15);
    }
}

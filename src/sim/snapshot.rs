//! Everything of thesis table 3 at one instant, read after a forward pass.

use super::{GeomClass, World, read3};
use crate::control::Observation;
use mujoco_rs::prelude::MjtObjBase;

/// One contact (MuJoCo's contact list), in the world frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactRow {
    /// Geom ids (names in [`super::Index::geom_names`]).
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
    /// Friction force along the contact frame's two tangent axes (N).
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
    /// Per link: the part that other links (self-collision) and other geoms exert (N).
    pub link_other_contact_force_n: Vec<[f64; 3]>,
    /// Per link: origin of the link's frame (m): the anchor of the joint to its parent (for the
    /// generated snake; the head's front end for link 0).
    pub link_origin_m: Vec<[f64; 3]>,
    /// Floor region under each link's centre in the step that starts at this instant: 0 = plain
    /// floor, `k + 1` = `ground.surfaces[k]` (filled by `Simulation::snapshot`; all 0 without
    /// surfaces).
    pub link_region: Vec<usize>,
    /// Per joint: angle (rad) and velocity (rad/s).
    pub joint_angle_rad: Vec<f64>,
    pub joint_velocity_rad_per_s: Vec<f64>,
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
    /// A snapshot sized for `n_links` links and `n_joints` joints.
    pub fn new(n_links: usize, n_joints: usize) -> Self {
        Self {
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
            link_other_contact_force_n: vec![[0.0; 3]; n_links],
            link_origin_m: vec![[0.0; 3]; n_links],
            link_region: vec![0; n_links],
            joint_angle_rad: vec![0.0; n_joints],
            joint_velocity_rad_per_s: vec![0.0; n_joints],
            actuator_force_nm: vec![[0.0; 4]; n_joints],
            joint_force_n: vec![[0.0; 3]; n_joints],
            joint_torque_nm: vec![[0.0; 3]; n_joints],
            observation_true: Observation::new(n_links, n_joints),
            observation_measured: Observation::new(n_links, n_joints),
            link_velocimeter_m_per_s: vec![[0.0; 3]; n_links],
            contacts: Vec::with_capacity(64),
            obstacle_weight: vec![0.0; n_links],
            time_secs: 0.0,
        }
    }

    /// Reads the world (after a forward pass) and the observations of this step.
    pub fn read(&mut self, world: &World, obs_true: &Observation, obs_measured: &Observation) {
        let d = &world.data;
        let idx = &world.index;
        let gravity = d.model_opt().gravity;
        self.time_secs = d.time();
        let xipos = d.xipos();
        let xquat = d.xquat();
        let xpos = d.xpos();
        let sensordata = d.sensordata();
        for (i, link) in idx.links.iter().enumerate() {
            self.link_position_m[i] = xipos[link.body];
            self.link_quat[i] = xquat[link.body];
            // mjOBJ_BODY: at the centre of mass, world orientation; [angular; linear].
            let v = d.object_velocity(MjtObjBase::mjOBJ_BODY, link.body, false);
            self.link_angular_velocity_rad_per_s[i] = [v[0], v[1], v[2]];
            self.link_velocity_m_per_s[i] = [v[3], v[4], v[5]];
            // MuJoCo's body acceleration is the proper acceleration (it starts the recursion
            // from -gravity, as an accelerometer does); add gravity back for the kinematic one.
            let a = d.object_acceleration(MjtObjBase::mjOBJ_BODY, link.body, false);
            self.link_angular_acceleration_rad_per_s2[i] = [a[0], a[1], a[2]];
            self.link_acceleration_m_per_s2[i] = [a[3] + gravity[0], a[4] + gravity[1], a[5] + gravity[2]];
            self.link_origin_m[i] = xpos[link.body];
            self.link_contact_force_n[i] = [0.0; 3];
            self.link_contact_torque_nm[i] = [0.0; 3];
            self.link_floor_force_n[i] = [0.0; 3];
            self.link_floor_torque_nm[i] = [0.0; 3];
            self.link_obstacle_force_n[i] = [0.0; 3];
            self.link_obstacle_torque_nm[i] = [0.0; 3];
            self.link_obstacle_point_m[i] = None;
            self.link_other_contact_force_n[i] = [0.0; 3];
            self.obstacle_weight[i] = 0.0;
            read3(sensordata, link.velocimeter_adr, &mut self.link_velocimeter_m_per_s[i]);
        }
        let qpos = d.qpos();
        let qvel = d.qvel();
        let actuator_force = d.actuator_force();
        for (j, joint) in idx.joints.iter().enumerate() {
            self.joint_angle_rad[j] = qpos[joint.qpos_adr];
            self.joint_velocity_rad_per_s[j] = qvel[joint.dof_adr];
            for (k, slot) in joint.actuators.iter().enumerate() {
                self.actuator_force_nm[j][k] = slot.map_or(0.0, |a| actuator_force[a]);
            }
            read3(sensordata, joint.force_adr, &mut self.joint_force_n[j]);
            read3(sensordata, joint.torque_adr, &mut self.joint_torque_nm[j]);
        }
        self.observation_true.copy_from(obs_true);
        self.observation_measured.copy_from(obs_measured);
        self.read_contacts(world);
    }

    fn read_contacts(&mut self, world: &World) {
        let d = &world.data;
        let idx = &world.index;
        let geom_body = d.model().geom_bodyid();
        self.contacts.clear();
        for (c, contact) in d.contact().iter().enumerate() {
            let f = d.contact_force(c);
            let fr = &contact.frame;
            let normal = [fr[0], fr[1], fr[2]];
            let mut force = [0.0; 3];
            for k in 0..3 {
                force[k] = f[0] * fr[k] + f[1] * fr[3 + k] + f[2] * fr[6 + k];
            }
            let geom = [contact.geom[0].max(0) as usize, contact.geom[1].max(0) as usize];
            let row = ContactRow {
                geom,
                body: [geom_body[geom[0]] as usize, geom_body[geom[1]] as usize],
                position_m: contact.pos,
                normal,
                distance_m: contact.dist,
                normal_force_n: f[0],
                friction_force_n: [f[1], f[2]],
                force_on_geom2_n: force,
            };
            for (side, sign) in [(0, -1.0), (1, 1.0)] {
                if let Some(Some(link)) = idx.geom_link.get(geom[side]) {
                    let link = *link;
                    add_to(&mut self.link_contact_force_n[link], force, sign);
                    let arm = sub(row.position_m, self.link_position_m[link]);
                    let moment = cross(arm, force);
                    add_to(&mut self.link_contact_torque_nm[link], moment, sign);
                    match idx.geom_class.get(geom[1 - side]) {
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
                        _ => add_to(&mut self.link_other_contact_force_n[link], force, sign),
                    }
                }
            }
            self.contacts.push(row);
        }
        // Weighted sums → weighted means (a contact without force has no point of application).
        for (point, &w) in self.link_obstacle_point_m.iter_mut().zip(&self.obstacle_weight) {
            match point {
                Some(p) if w > 0.0 => p.iter_mut().for_each(|x| *x /= w),
                _ => *point = None,
            }
        }
    }

    /// Largest contact normal force in this snapshot (N).
    pub fn peak_contact_force_n(&self) -> f64 {
        self.contacts.iter().map(|c| c.normal_force_n).fold(0.0, f64::max)
    }
}

//! Reading a [`Snapshot`] (everything of thesis table 3 at one instant) out of the engine.

use super::{OwnContact, World, read3};
use crate::control::Observation;
use crate::state::{ContactRow, Snapshot};
use mujoco_rs::prelude::MjtObjBase;

impl World {
    /// Reads the state after a forward pass, and the observations of this step, into
    /// `snapshot` (no allocation, except when a step has more contacts than any before it).
    /// `link_region` is left as it is (the ground model fills it).
    pub fn read_snapshot(&self, snapshot: &mut Snapshot, obs_true: &Observation, obs_measured: &Observation) {
        self.read_snapshot_with(snapshot, obs_true, obs_measured, &[]);
    }

    /// [`World::read_snapshot`], with the contacts of SimSerpent's own contact law (link–ground
    /// and link–obstacle, which MuJoCo's contact list does not hold then) after MuJoCo's rows
    /// (see [`super::Ground::own_contacts`]).
    pub fn read_snapshot_with(
        &self,
        snapshot: &mut Snapshot,
        obs_true: &Observation,
        obs_measured: &Observation,
        own: &[OwnContact],
    ) {
        let s = snapshot;
        let d = &self.data;
        let idx = &self.index;
        let gravity = d.model_opt().gravity;
        s.time_secs = d.time();
        let xipos = d.xipos();
        let xquat = d.xquat();
        let xpos = d.xpos();
        let sensordata = d.sensordata();
        for (i, link) in idx.links.iter().enumerate() {
            s.link_mass_kg[i] = link.mass_kg;
            s.link_position_m[i] = xipos[link.body];
            s.link_quat[i] = xquat[link.body];
            // mjOBJ_BODY: at the centre of mass, world orientation; [angular; linear].
            let v = d.object_velocity(MjtObjBase::mjOBJ_BODY, link.body, false);
            s.link_angular_velocity_rad_per_s[i] = [v[0], v[1], v[2]];
            s.link_velocity_m_per_s[i] = [v[3], v[4], v[5]];
            // MuJoCo's body acceleration is the proper acceleration (it starts the recursion
            // from -gravity, as an accelerometer does); add gravity back for the kinematic one.
            let a = d.object_acceleration(MjtObjBase::mjOBJ_BODY, link.body, false);
            s.link_angular_acceleration_rad_per_s2[i] = [a[0], a[1], a[2]];
            s.link_acceleration_m_per_s2[i] = [a[3] + gravity[0], a[4] + gravity[1], a[5] + gravity[2]];
            s.link_origin_m[i] = xpos[link.body];
            read3(sensordata, link.velocimeter_adr, &mut s.link_velocimeter_m_per_s[i]);
        }
        let qpos = d.qpos();
        let qvel = d.qvel();
        let qfrc_actuator = d.qfrc_actuator();
        let actuator_force = d.actuator_force();
        for (j, joint) in idx.joints.iter().enumerate() {
            s.joint_angle_rad[j] = qpos[joint.qpos_adr];
            s.joint_velocity_rad_per_s[j] = qvel[joint.dof_adr];
            s.joint_actuator_torque_nm[j] = qfrc_actuator[joint.dof_adr];
            for (k, slot) in joint.actuators.iter().enumerate() {
                s.actuator_force_nm[j][k] = slot.map_or(0.0, |a| actuator_force[a]);
            }
            read3(sensordata, joint.force_adr, &mut s.joint_force_n[j]);
            read3(sensordata, joint.torque_adr, &mut s.joint_torque_nm[j]);
        }
        s.observation_true.copy_from(obs_true);
        s.observation_measured.copy_from(obs_measured);
        self.read_contacts(s, own);
    }

    /// The contacts' normal forces of the last forward pass (the forces of the step that starts
    /// from it), per link: the vector sum over the link's contacts — MuJoCo's and those of
    /// SimSerpent's own contact law (`own`, [`super::Ground::own_contacts`]) — into `out` (N,
    /// world; sized for the links). Returns the largest single contact normal force (N). No
    /// allocation.
    pub fn link_contact_normal_forces(&self, own: &[OwnContact], out: &mut [[f64; 3]]) -> f64 {
        let d = &self.data;
        let idx = &self.index;
        out.fill([0.0; 3]);
        let mut largest_n: f64 = 0.0;
        // The normal points from geom 0 to geom 1: geom 1 feels +f·n, geom 0 −f·n.
        let mut add = |geom: [usize; 2], f: f64, n: [f64; 3]| {
            largest_n = largest_n.max(f.abs());
            for (side, sign) in [(1, 1.0), (0, -1.0)] {
                if let Some(Some(link)) = idx.geom_link.get(geom[side])
                    && let Some(acc) = out.get_mut(*link)
                {
                    for k in 0..3 {
                        acc[k] += sign * f * n[k];
                    }
                }
            }
        };
        for (c, contact) in d.contact().iter().enumerate() {
            let fr = &contact.frame;
            let geom = [contact.geom[0].max(0) as usize, contact.geom[1].max(0) as usize];
            add(geom, d.contact_force(c)[0], [fr[0], fr[1], fr[2]]);
        }
        for c in own {
            add(c.geom, c.normal_force_n, c.normal);
        }
        largest_n
    }

    fn read_contacts(&self, s: &mut Snapshot, own: &[OwnContact]) {
        let d = &self.data;
        let idx = &self.index;
        let geom_body = d.model().geom_bodyid();
        s.begin_contacts();
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
            let link = geom.map(|g| idx.geom_link.get(g).copied().flatten());
            let class = geom.map(|g| idx.geom_class.get(g).copied());
            s.add_contact(row, link, class);
        }
        for c in own {
            let row = ContactRow {
                geom: c.geom,
                body: c.geom.map(|g| geom_body[g] as usize),
                position_m: c.position_m,
                normal: c.normal,
                distance_m: c.distance_m,
                normal_force_n: c.normal_force_n,
                friction_force_n: [0.0; 2],
                force_on_geom2_n: c.normal.map(|x| c.normal_force_n * x),
            };
            let link = c.geom.map(|g| idx.geom_link.get(g).copied().flatten());
            let class = c.geom.map(|g| idx.geom_class.get(g).copied());
            s.add_contact(row, link, class);
        }
        s.end_contacts();
    }
}

//! The planar contact Jacobian the contact laws share: the snake in the ground plane from what
//! the robot senses, which flank of the body a contact pushes on, and the joint torques of
//! contact forces.
//!
//! **The body.** Link headings θᵢ and joint positions come from [`planar_chain`]'s rule: the
//! head's yaw (calibrated once from the head pose, then integrated from the head gyro, as the
//! robot would) and position, and the encoders; link i's front end is oᵢ (o₀ the head's tip),
//! joint j sits at o_{j+1}, between links j and j+1.
//!
//! **Flanks.** With g the goal direction, a contact force f on the body is *propulsive* when
//! f·g > 0 (the peg pushes the body toward the goal) and *resisting* when f·g < 0. Its lateral
//! component on link i is pᵢ = f·nᵢ with nᵢ = (−sin θᵢ, cos θᵢ) the link's left normal: p < 0
//! means the peg is on the link's left.
//!
//! **Contact Jacobian.** Taking the head as the base (the head-side chain held, joint j turning
//! the links behind it), a force f at point p on link i > j exerts on joint j the torque
//! τⱼ = ((p − o_{j+1}) × f)_z, so the joint torques of a set of contacts are τ = Jᵀf with
//! Jⱼ,ᵢ = ẑ × (p − o_{j+1}) for i > j and 0 otherwise (Liljebäck et al. 2013, ch. 10, in
//! relative joint angles). A joint torque increment Δτ on a servo of stiffness k becomes a
//! set-point offset Δq = Δτ/k. Bending joints j = i − 1 and j = i of a contacted link i with
//! Δq = +c·pᵢ (c > 0) wraps the body around its peg (presses into it); Δq = −c·pᵢ bends away.

use super::{GyroYaw, Observation, planar_chain};
use crate::estimation::ContactEstimates;

/// Which way a contact force pushes relative to the goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flank {
    /// f·g > 0: the peg pushes the body toward the goal.
    Propulsive,
    /// f·g < 0: the peg holds the body back.
    Resisting,
}

/// The flank of a horizontal contact force `force_n` against the goal direction `goal`
/// (unit vector); `None` for a force exactly across the goal (or zero).
pub fn flank(force_n: [f64; 2], goal: [f64; 2]) -> Option<Flank> {
    let along = force_n[0] * goal[0] + force_n[1] * goal[1];
    if along > 0.0 {
        Some(Flank::Propulsive)
    } else if along < 0.0 {
        Some(Flank::Resisting)
    } else {
        None
    }
}

/// The planar body a contact law reads: sized once, updated every step without allocating.
#[derive(Debug, Clone)]
pub struct PlanarBody {
    yaw_joint: Vec<bool>,
    link_length_m: f64,
    yaw: GyroYaw,
    /// Link headings θᵢ (rad).
    pub heading_rad: Vec<f64>,
    /// Front end oᵢ of each link (m); joint j is at `front_m[j + 1]`.
    pub front_m: Vec<[f64; 2]>,
    /// The centre of mass (m), the mean of the link centres.
    pub com_m: [f64; 2],
}

impl PlanarBody {
    /// A body of `n_links` links `link_length_m` long; `yaw_joint[j]` says whether joint j turns
    /// in the ground plane.
    pub fn new(n_links: usize, link_length_m: f64, yaw_joint: Vec<bool>) -> Self {
        Self {
            yaw_joint,
            link_length_m,
            yaw: GyroYaw::default(),
            heading_rad: vec![0.0; n_links],
            front_m: vec![[0.0; 2]; n_links],
            com_m: [0.0; 2],
        }
    }

    /// Forgets the head yaw (the next [`PlanarBody::sense`] calibrates it again).
    pub fn reset(&mut self) {
        self.yaw.reset();
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.heading_rad.len()
    }

    /// Updates headings, joint positions and centre of mass from `obs`; returns the time step
    /// since the last call (s; 0 at the first).
    pub fn sense(&mut self, obs: &Observation) -> f64 {
        let dt = self.yaw.update(obs);
        let head = [obs.head_position_m[0], obs.head_position_m[1]];
        let (_, com) = planar_chain(
            self.yaw.yaw_rad,
            head,
            &obs.joint_angle_rad,
            &self.yaw_joint,
            self.link_length_m,
            &mut self.heading_rad,
        );
        self.com_m = com;
        let l = self.link_length_m;
        let mut o = head;
        for i in 0..self.front_m.len() {
            if i > 0 {
                let th = self.heading_rad[i - 1];
                o = [o[0] - l * th.cos(), o[1] - l * th.sin()];
            }
            self.front_m[i] = o;
        }
        dt
    }

    /// Link i's centre (m).
    pub fn centre_m(&self, i: usize) -> [f64; 2] {
        let (o, th) = (self.front_m[i], self.heading_rad[i]);
        [o[0] - 0.5 * self.link_length_m * th.cos(), o[1] - 0.5 * self.link_length_m * th.sin()]
    }

    /// Link i's left normal nᵢ.
    pub fn normal(&self, i: usize) -> [f64; 2] {
        let th = self.heading_rad[i];
        [-th.sin(), th.cos()]
    }

    /// Where link i's contact acts (m): the estimate's point, or the link's centre.
    pub fn contact_point_m(&self, contacts: &ContactEstimates, i: usize) -> [f64; 2] {
        contacts.contact_point_m.get(i).copied().flatten().map_or_else(|| self.centre_m(i), |p| [p[0], p[1]])
    }

    /// Whether joint j turns in the ground plane.
    pub fn is_yaw_joint(&self, j: usize) -> bool {
        self.yaw_joint.get(j).copied().unwrap_or(true)
    }

    /// Adds to `torque_nm` (one per joint) the joint torques τ = Jᵀf of force `force_n` acting at
    /// `point_m` on link `i` (head-side chain as the base; pitch joints get none).
    pub fn add_joint_torques(&self, i: usize, point_m: [f64; 2], force_n: [f64; 2], torque_nm: &mut [f64]) {
        for (j, tau) in torque_nm.iter_mut().enumerate().take(i) {
            if !self.is_yaw_joint(j) {
                continue;
            }
            let o = self.front_m[j + 1];
            let r = [point_m[0] - o[0], point_m[1] - o[1]];
            *tau += r[0] * force_n[1] - r[1] * force_n[0];
        }
    }
}

/// The stiffness (N·m/rad) through which a joint-torque increment becomes a set-point offset for
/// the configured actuator kind: the position servo's kp, the integrated-velocity servo's kp, or
/// the joint PID's kp (torque); `None` for velocity servos (no stiffness).
pub fn servo_stiffness_nm_per_rad(config: &crate::config::Config) -> Option<f64> {
    use crate::config::ControlMethod;
    let c = &config.control;
    match c.method {
        ControlMethod::Position => Some(c.position_kp_nm_per_rad),
        ControlMethod::Intvelocity => Some(c.intvelocity_kp_nm_per_rad),
        ControlMethod::Torque => Some(c.pid_kp_nm_per_rad * c.torque_gear),
        ControlMethod::Velocity => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight body along +x with its head tip at the origin.
    fn straight(n_links: usize) -> PlanarBody {
        let mut body = PlanarBody::new(n_links, 0.2, vec![true; n_links - 1]);
        let mut obs = Observation::new(n_links, n_links - 1);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        body.sense(&obs);
        body
    }

    #[test]
    fn flanks_follow_the_force_along_the_goal() {
        assert_eq!(flank([1.0, 5.0], [1.0, 0.0]), Some(Flank::Propulsive));
        assert_eq!(flank([-0.1, 5.0], [1.0, 0.0]), Some(Flank::Resisting));
        assert_eq!(flank([0.0, 5.0], [1.0, 0.0]), None);
    }

    #[test]
    fn joint_positions_and_the_jacobian_of_a_straight_body() {
        let body = straight(4);
        // Joint j at x = −0.2·(j + 1).
        assert!((body.front_m[2][0] + 0.4).abs() < 1e-15 && body.front_m[2][1].abs() < 1e-15);
        assert!((body.centre_m(3)[0] + 0.7).abs() < 1e-12);
        // 1 N along +y at link 2's centre (x = −0.5): joint 0 (at −0.2) feels r × f = −0.3,
        // joint 1 (at −0.4) −0.1, joint 2 (behind the link) nothing.
        let mut tau = [0.0; 3];
        body.add_joint_torques(2, body.centre_m(2), [0.0, 1.0], &mut tau);
        assert!((tau[0] + 0.3).abs() < 1e-12 && (tau[1] + 0.1).abs() < 1e-12 && tau[2] == 0.0, "{tau:?}");
    }

    #[test]
    fn the_jacobian_is_the_virtual_work_of_a_joint_rotation() {
        // τⱼ = ∂p/∂qⱼ · f: turning joint j by ε moves the point by ε·ẑ × (p − oⱼ₊₁); check by finite
        // differences on a bent body.
        let n = 5;
        let q = [0.3, -0.5, 0.2, 0.4];
        let mut obs = Observation::new(n, n - 1);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.joint_angle_rad.copy_from_slice(&q);
        let mut body = PlanarBody::new(n, 0.2, vec![true; n - 1]);
        body.sense(&obs);
        let (i, f) = (3, [0.7, -1.3]);
        // The point 0.05 m behind link 3's front end, in link coordinates.
        let point = |b: &PlanarBody| {
            let (o, th) = (b.front_m[i], b.heading_rad[i]);
            [o[0] - 0.05 * th.cos(), o[1] - 0.05 * th.sin()]
        };
        let mut tau = [0.0; 4];
        body.add_joint_torques(i, point(&body), f, &mut tau);
        for (j, expected) in tau.iter().enumerate() {
            let eps = 1e-6;
            let mut moved = PlanarBody::new(n, 0.2, vec![true; n - 1]);
            let mut o2 = obs.clone();
            o2.joint_angle_rad[j] += eps;
            moved.sense(&o2);
            let (p0, p1) = (point(&body), point(&moved));
            let work = ((p1[0] - p0[0]) * f[0] + (p1[1] - p0[1]) * f[1]) / eps;
            assert!((work - expected).abs() < 1e-5, "joint {j}: {work} vs {expected}");
        }
    }
}

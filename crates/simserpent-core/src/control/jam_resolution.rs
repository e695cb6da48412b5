//! Propulsion-aware jam resolution through the contact Jacobian (Liljebäck et al.).
//!
//! Sources: P. Liljebäck, K. Y. Pettersen, Ø. Stavdahl, J. T. Gravdahl, "Hybrid modelling and
//! control of obstacle-aided snake robot locomotion", *IEEE Transactions on Robotics* 26(5)
//! (2010) 781–799 (a jam: the contact forces cannot propel the body toward the goal; the joint
//! torques that do are found from the contact points and normals through the contact Jacobian);
//! P. Liljebäck, K. Y. Pettersen, Ø. Stavdahl, J. T. Gravdahl, *Snake Robots: Modelling,
//! Mechatronics, and Control*, Springer 2013, chapters 10–11 (the jam resolution of an
//! obstacle-aided gait, and its experiments with Kulko).
//!
//! On the wave qⱼᵇ(t) of `[gait.sine_wave]`, joint j's set-point is qⱼᵇ(t) + oⱼ(t), with the
//! offsets relaxing toward a target, τ_o·ȯⱼ = ōⱼ − oⱼ (|oⱼ| ≤ o_max). Outside a jam ōⱼ = 0. A jam
//! is detected when the centre of mass (head pose and encoders) gains less than
//! `jam_min_progress_m` along the goal g within `jam_window_secs`; the resolution then acts for
//! `resolve_secs`. Each contacted link k has the contact normal n̂ₖ = fₖ/|fₖ| (the estimated
//! obstacle force is a normal force on the frictionless-enough peg) at the point pₖ; the
//! contacts that can propel are P = {k : n̂ₖ·g ≥ c_min}.
//!
//! ```text
//!   P ≠ ∅:  ρₖ = F·(n̂ₖ·g) / Σ_{P} n̂·g  (k ∈ P),     Δτ = −Σ_{k∈P} ρₖ·Jₖᵀn̂ₖ,     ōⱼ = Δτⱼ / k_s
//!   P = ∅:  ōⱼ = −qⱼᵇ(t) for the joints j ∈ {k − 1, k} at the resisting contacts k (f·g < 0)
//! ```
//!
//! Δτ is the joint torque that makes the body push each propelling peg with ρₖ more (the peg
//! pushes back with ρₖn̂ₖ, so the contact forces' sum along the goal grows by F·Σρₖ(n̂ₖ·g)/F > 0);
//! Jₖᵀ is the transposed contact Jacobian of module [`super::contact_jacobian`] and k_s the
//! servo stiffness (`control.position_kp_nm_per_rad` for position servos; the PID's kp for
//! torque; `intvelocity_kp_nm_per_rad`), which turns a torque increment into a set-point
//! offset. When no contact can propel, the bends at the resisting contacts are released
//! (straightened). With `feedback = false` the offsets stay 0 and the set-points are the sine
//! wave's, bit for bit.

use super::contact_jacobian::{Flank, PlanarBody, flank, servo_stiffness_nm_per_rad};
use super::{
    Command, ContactFeed, Controller, HeadingHold, Observation, Pid, SineWave, command_joint, feel, joint_pid,
    low_pass_gain, yaw_joints,
};
use crate::config::{Config, ControlMethod};
use crate::control::JointTrajectory;
use crate::estimation::ContactEstimates;
use crate::state::Snapshot;

/// What the resolution does at the moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Resolution {
    /// No jam: the wave alone (offsets relax to 0).
    Idle,
    /// Jammed, some contacts can propel: press on them.
    Press,
    /// Jammed, none can: release the bends at the resisting contacts.
    Release,
}

/// The controller of `control.controller = "jam_resolution"`.
pub struct JamResolution {
    wave: SineWave,
    /// The heading-hold term (`heading_gain` > 0), which sets the wave's offset.
    heading: Option<HeadingHold>,
    method: ControlMethod,
    pids: Vec<Pid>,
    dt_secs: f64,
    contacts: ContactFeed,
    feedback: bool,
    goal: [f64; 2],
    jam_window_secs: f64,
    jam_min_progress_m: f64,
    resolve_secs: f64,
    push_force_n: f64,
    min_propulsion: f64,
    offset_filter_secs: f64,
    max_offset_rad: f64,
    stiffness_nm_per_rad: f64,
    body: PlanarBody,
    target_rad: Vec<f64>,
    offset_rad: Vec<f64>,
    torque_nm: Vec<f64>,
    base_rad: Vec<f64>,
    base_velocity_rad_per_s: Vec<f64>,
    /// The progress (m along the goal) and time of the last advance by `jam_min_progress_m`.
    anchor: Option<(f64, f64)>,
    resolve_until_secs: f64,
    resolution: Resolution,
}

impl JamResolution {
    /// The controller of `config` for `n_joints` joints (validation refuses velocity servos when
    /// it is selected).
    pub fn from_config(config: &Config, n_joints: usize) -> Self {
        let j = &config.jam_resolution;
        let goal = j.goal_heading_deg.to_radians();
        let n_links = n_joints + 1;
        Self {
            wave: SineWave::from_config(config),
            method: config.control.method,
            pids: vec![joint_pid(config); n_joints],
            dt_secs: config.general.timestep_secs,
            contacts: ContactFeed::new(config, j.contacts, n_links),
            heading: HeadingHold::for_law(
                config,
                n_joints,
                j.heading_gain,
                j.heading_max_offset_deg,
                j.goal_heading_deg,
            ),
            feedback: j.feedback,
            goal: [goal.cos(), goal.sin()],
            jam_window_secs: j.jam_window_secs,
            jam_min_progress_m: j.jam_min_progress_m,
            resolve_secs: j.resolve_secs,
            push_force_n: j.push_force_n,
            min_propulsion: j.min_propulsion,
            offset_filter_secs: j.offset_filter_secs,
            max_offset_rad: j.max_offset_deg.to_radians(),
            // Velocity servos are refused by validation; a zero stiffness sends no offsets.
            stiffness_nm_per_rad: servo_stiffness_nm_per_rad(config).unwrap_or(0.0),
            body: PlanarBody::new(n_links, config.snake.link_length_m, yaw_joints(config, n_joints)),
            target_rad: vec![0.0; n_joints],
            offset_rad: vec![0.0; n_joints],
            torque_nm: vec![0.0; n_joints],
            base_rad: vec![0.0; n_joints],
            base_velocity_rad_per_s: vec![0.0; n_joints],
            anchor: None,
            resolve_until_secs: f64::NEG_INFINITY,
            resolution: Resolution::Idle,
        }
    }

    /// What the last update did.
    pub fn resolution(&self) -> Resolution {
        self.resolution
    }

    /// The offset targets ōⱼ of the last update (rad).
    pub fn targets_rad(&self) -> &[f64] {
        &self.target_rad
    }

    /// The joint offsets oⱼ of the last update (rad).
    pub fn offsets_rad(&self) -> &[f64] {
        &self.offset_rad
    }

    /// The jam rule on the centre of mass's progress along the goal.
    fn jammed(&mut self, t: f64) -> bool {
        let com = self.body.com_m;
        let progress = com[0] * self.goal[0] + com[1] * self.goal[1];
        let (best, since) = *self.anchor.get_or_insert((progress, t));
        if progress >= best + self.jam_min_progress_m {
            self.anchor = Some((progress, t));
            return false;
        }
        if t - since >= self.jam_window_secs {
            // A jam: resolve, and measure the progress afresh from here.
            self.anchor = Some((progress, t));
            return true;
        }
        false
    }

    /// The offset targets of a jammed body with these contacts.
    fn resolve(&mut self, contacts: &ContactEstimates) {
        self.target_rad.iter_mut().for_each(|x| *x = 0.0);
        self.torque_nm.iter_mut().for_each(|x| *x = 0.0);
        let n_links = self.body.n_links().min(contacts.contact.len());
        let touching = |i: usize| contacts.active && contacts.contact[i];
        let normal = |i: usize| {
            let f = contacts.obstacle_force_n[i];
            let m = f[0].hypot(f[1]);
            if m > 0.0 { [f[0] / m, f[1] / m] } else { [0.0; 2] }
        };
        let mut sum_along = 0.0;
        for i in (0..n_links).filter(|&i| touching(i)) {
            let n = normal(i);
            let along = n[0] * self.goal[0] + n[1] * self.goal[1];
            if along >= self.min_propulsion && along > 0.0 {
                sum_along += along;
            }
        }
        if sum_along > 0.0 {
            self.resolution = Resolution::Press;
            for i in (0..n_links).filter(|&i| touching(i)) {
                let n = normal(i);
                let along = n[0] * self.goal[0] + n[1] * self.goal[1];
                if along >= self.min_propulsion && along > 0.0 {
                    let rho = self.push_force_n * along / sum_along;
                    let p = self.body.contact_point_m(contacts, i);
                    self.body.add_joint_torques(i, p, [-rho * n[0], -rho * n[1]], &mut self.torque_nm);
                }
            }
            if self.stiffness_nm_per_rad > 0.0 {
                for (o, tau) in self.target_rad.iter_mut().zip(&self.torque_nm) {
                    *o = tau / self.stiffness_nm_per_rad;
                }
            }
        } else {
            self.resolution = Resolution::Release;
            let nj = self.target_rad.len();
            for i in (0..n_links).filter(|&i| touching(i)) {
                let f = contacts.obstacle_force_n[i];
                if flank([f[0], f[1]], self.goal) != Some(Flank::Resisting) {
                    continue;
                }
                for j in [i.wrapping_sub(1), i] {
                    if j < nj && self.body.is_yaw_joint(j) {
                        self.target_rad[j] = -self.base_rad[j];
                    }
                }
            }
        }
    }

    fn step(&mut self, obs: &Observation, contacts: &ContactEstimates, cmd: &mut Command) {
        let t = obs.time_secs;
        if let Some(h) = self.heading.as_mut() {
            self.wave.offset_rad = h.wave_offset_rad(obs);
        }
        self.wave.targets(t, &mut self.base_rad, &mut self.base_velocity_rad_per_s);
        if self.feedback {
            let dt = self.body.sense(obs);
            if self.jammed(t) {
                self.resolve_until_secs = t + self.resolve_secs;
            }
            if t < self.resolve_until_secs {
                self.resolve(contacts);
            } else {
                self.resolution = Resolution::Idle;
                self.target_rad.iter_mut().for_each(|x| *x = 0.0);
            }
            let k = if dt > 0.0 { low_pass_gain(dt, self.offset_filter_secs) } else { 0.0 };
            for (o, target) in self.offset_rad.iter_mut().zip(&self.target_rad) {
                *o = (*o + k * (target - *o)).clamp(-self.max_offset_rad, self.max_offset_rad);
            }
        }
        for j in 0..self.base_rad.len() {
            let angle = self.base_rad[j] + self.offset_rad[j];
            command_joint(
                self.method,
                cmd,
                j,
                angle,
                self.base_velocity_rad_per_s[j],
                obs,
                &mut self.pids[j],
                self.dt_secs,
            );
        }
    }
}

impl Controller for JamResolution {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
        self.body.reset();
        self.target_rad.iter_mut().for_each(|x| *x = 0.0);
        self.offset_rad.iter_mut().for_each(|x| *x = 0.0);
        self.anchor = None;
        self.resolve_until_secs = f64::NEG_INFINITY;
        self.resolution = Resolution::Idle;
    }

    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        feel(self, |c| &mut c.contacts, Self::step, obs, None, cmd);
    }

    fn needs_full_state(&self) -> bool {
        self.feedback && self.contacts.needs_full_state()
    }

    fn update_with_state(&mut self, obs: &Observation, state: &Snapshot, cmd: &mut Command) {
        feel(self, |c| &mut c.contacts, Self::step, obs, Some(state), cmd);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ControllerKind, GaitKind};

    fn config() -> Config {
        let mut c = Config::default();
        c.control.controller = ControllerKind::JamResolution;
        c.gait.kind = GaitKind::SineWave;
        c.gait.sine_wave.amplitude_deg = 60.0;
        c.gait.sine_wave.phase_lag_deg = 30.0;
        c.gait.ramp_secs = 0.0;
        c.estimation.enabled = true;
        c
    }

    /// A straight body along +x standing still at time `t`, with a 5-N contact on link 5 from a
    /// peg on its left (force −y) with the given x component.
    fn observation(t: f64, force_x_n: f64) -> Observation {
        let mut obs = Observation::new(10, 9);
        obs.time_secs = t;
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.contacts = ContactEstimates::new(10);
        obs.contacts.active = true;
        obs.contacts.contact[5] = true;
        obs.contacts.obstacle_force_n[5] = [force_x_n, -5.0, 0.0];
        obs
    }

    /// Runs `ctl` on a still body until the jam rule fires and one more step.
    fn until_jammed(ctl: &mut JamResolution, c: &Config, force_x_n: f64) {
        let dt = c.general.timestep_secs;
        let steps = (c.jam_resolution.jam_window_secs / dt).round() as usize + 2;
        let mut cmd = Command::new(9);
        for k in 0..steps {
            ctl.update(&observation(k as f64 * dt, force_x_n), &mut cmd);
        }
    }

    #[test]
    fn a_still_body_jams_after_the_window_only() {
        let c = config();
        let mut ctl = JamResolution::from_config(&c, 9);
        let mut cmd = Command::new(9);
        let dt = c.general.timestep_secs;
        let window = (c.jam_resolution.jam_window_secs / dt).round() as usize;
        for k in 0..window {
            ctl.update(&observation(k as f64 * dt, 2.0), &mut cmd);
            assert_eq!(ctl.resolution(), Resolution::Idle, "step {k}");
        }
        ctl.update(&observation(window as f64 * dt, 2.0), &mut cmd);
        assert_eq!(ctl.resolution(), Resolution::Press);
    }

    #[test]
    fn a_propulsive_contact_is_pressed_through_the_jacobian() {
        let c = config();
        let mut ctl = JamResolution::from_config(&c, 9);
        until_jammed(&mut ctl, &c, 2.0);
        assert_eq!(ctl.resolution(), Resolution::Press);
        // One propelling contact: ρ = F along n̂. Pressing a peg on the left of link 5 wraps the
        // body around it (joints in front of the link turn negative, module contact_jacobian),
        // joints behind the link are not involved, and the offsets are Δτ / kp.
        let n = [2.0 / 29f64.sqrt(), -5.0 / 29f64.sqrt()];
        let f = c.jam_resolution.push_force_n;
        let mut tau = [0.0; 9];
        ctl.body.add_joint_torques(5, ctl.body.centre_m(5), [-f * n[0], -f * n[1]], &mut tau);
        for (j, t) in tau.iter().enumerate() {
            let expected = t / c.control.position_kp_nm_per_rad;
            assert!((ctl.targets_rad()[j] - expected).abs() < 1e-12, "joint {j}");
        }
        assert!(ctl.targets_rad()[4] < 0.0 && ctl.targets_rad()[0] < ctl.targets_rad()[4]);
        assert!(ctl.targets_rad()[5..].iter().all(|x| *x == 0.0));
        // The pressed contact force's sum along the goal grows: ρ·n̂·g > 0.
        assert!(f * n[0] > 0.0);
    }

    #[test]
    fn a_resisting_contact_releases_its_bends() {
        let c = config();
        let mut ctl = JamResolution::from_config(&c, 9);
        until_jammed(&mut ctl, &c, -2.0);
        assert_eq!(ctl.resolution(), Resolution::Release);
        // Joints 4 and 5 (both ends of link 5) straighten: their targets cancel the wave.
        let t = ((c.jam_resolution.jam_window_secs / c.general.timestep_secs).round() + 1.0) * c.general.timestep_secs;
        let w = &c.gait.sine_wave;
        for j in [4usize, 5] {
            let base = w.amplitude_deg.to_radians()
                * (std::f64::consts::TAU * w.frequency_hz * t - j as f64 * w.phase_lag_deg.to_radians()).sin();
            assert!((ctl.targets_rad()[j] + base).abs() < 1e-9, "joint {j}: {} vs {}", ctl.targets_rad()[j], -base);
        }
        assert!(ctl.targets_rad().iter().enumerate().all(|(j, x)| j == 4 || j == 5 || *x == 0.0));
    }

    #[test]
    fn without_feedback_it_is_the_sine_wave_bit_for_bit() {
        let mut c = config();
        c.jam_resolution.feedback = false;
        c.gait.ramp_secs = 1.0;
        let mut ctl = JamResolution::from_config(&c, 9);
        let mut open = super::super::TrajectoryController::from_config(&c, 9);
        let (mut a, mut b) = (Command::new(9), Command::new(9));
        for k in 0..3000 {
            let obs = observation(k as f64 * 0.003, 2.0);
            ctl.update(&obs, &mut a);
            open.update(&obs, &mut b);
            assert_eq!(a.position_rad, b.position_rad);
        }
    }
}

//! Shape-based directional admittance with a mode switch when wedged.
//!
//! Sources: M. Travers, J. Whitman, H. Choset, "Shape-based coordination in locomotion
//! control", *International Journal of Robotics Research* 37(10) (2018) 1253–1268 (shape-based
//! compliance: the gait's shape parameters, not the joints, obey an admittance driven by the
//! external forces projected onto them); T. Wang, J. Whitman, M. Travers, H. Choset,
//! "Directional compliance in obstacle-aided navigation for snake robots", American Control
//! Conference 2020, 2458–2463 (the shape complies only in the direction that relieves contacts
//! opposing the motion, and a rule changes mode when the body is wedged).
//!
//! The wave of `[gait.sine_wave]`, qⱼᵇ(t) = r(t)·(A·sin φⱼ + φ₀) with φⱼ = ωt − jδ, gets one
//! amplitude βʷ per body window w = 0..W−1 (Gaussian windows gʷ(j) = exp(−½((j − cʷ)/σ)²) centred
//! at cʷ = (w + ½)·N_j/W − ½, normalised so that Σ_w gʷ(j) = 1):
//!
//! ```text
//!   qⱼ(t)  = qⱼᵇ(t) + r(t)·sin φⱼ · Σ_w gʷ(j)·(βʷ − A)
//!   B·β̇ʷ  = Fʷ − K·(βʷ − A),        βʷ ∈ [β_min, β_max]
//!   Fʷ     = Σⱼ ∂qⱼ/∂βʷ · τⱼ  = Σⱼ r(t)·gʷ(j)·sin φⱼ · τⱼ,     τ = Jᵀf over the *resisting* contacts
//! ```
//!
//! (τ = Jᵀf: module [`super::contact_jacobian`]; f the contact estimates' horizontal obstacle
//! forces, a contact resisting when f·g < 0 for the goal direction g). Complying to the
//! generalised force moves each window's amplitude the way the resisting pegs push it, so the
//! shape gives way where the body is held back and keeps pushing where it is propelled.
//!
//! **Mode switch.** The body is wedged when the low-pass filtered sum of the resisting forces'
//! components against the goal exceeds `wedge_force_n` while the filtered speed of the centre of
//! mass (from the head's pose and the encoders) along the goal stays below `wedge_speed_m_per_s`,
//! for `wedge_secs`. It then complies for `escape_secs` with every contact (propulsive ones too)
//! at the stiffness K·`escape_stiffness_ratio`, and returns. With `feedback = false` every βʷ
//! stays A and the set-points are the sine wave's, bit for bit.

use super::contact_jacobian::{Flank, PlanarBody, flank};
use super::{
    Command, ContactFeed, Controller, HeadingHold, Observation, Pid, SineWave, command_joint, feel, joint_pid,
    low_pass_gain, yaw_joints,
};
use crate::config::{Config, ControlMethod};
use crate::control::JointTrajectory;
use crate::estimation::ContactEstimates;
use crate::state::Snapshot;

/// The controller of `control.controller = "directional_admittance"`.
pub struct DirectionalAdmittance {
    wave: SineWave,
    /// The heading-hold term (`heading_gain` > 0), which sets the wave's offset.
    heading: Option<HeadingHold>,
    method: ControlMethod,
    pids: Vec<Pid>,
    dt_secs: f64,
    contacts: ContactFeed,
    feedback: bool,
    goal: [f64; 2],
    /// gʷ(j), row w.
    window: Vec<Vec<f64>>,
    stiffness_nm_per_rad: f64,
    damping_nm_s_per_rad: f64,
    min_amplitude_rad: f64,
    max_amplitude_rad: f64,
    wedge_force_n: f64,
    wedge_speed_m_per_s: f64,
    wedge_secs: f64,
    filter_secs: f64,
    escape_stiffness_ratio: f64,
    escape_secs: f64,
    body: PlanarBody,
    /// βʷ (rad).
    amplitude_rad: Vec<f64>,
    /// Fʷ of the last update (N·m).
    generalised_force_nm: Vec<f64>,
    torque_nm: Vec<f64>,
    base_rad: Vec<f64>,
    base_velocity_rad_per_s: Vec<f64>,
    resist_n: f64,
    speed_m_per_s: f64,
    last_com_m: Option<[f64; 2]>,
    wedged_since_secs: Option<f64>,
    escape_until_secs: f64,
}

impl DirectionalAdmittance {
    /// The controller of `config` for `n_joints` joints.
    pub fn from_config(config: &Config, n_joints: usize) -> Self {
        let a = &config.directional_admittance;
        let wave = SineWave::from_config(config);
        let windows = a.windows.max(1);
        let mut window = vec![vec![0.0; n_joints]; windows];
        for j in 0..n_joints {
            let mut sum = 0.0;
            for (k, row) in window.iter_mut().enumerate() {
                let c = (k as f64 + 0.5) * n_joints as f64 / windows as f64 - 0.5;
                row[j] = (-0.5 * ((j as f64 - c) / a.window_sigma_joints).powi(2)).exp();
                sum += row[j];
            }
            for row in window.iter_mut() {
                row[j] /= sum;
            }
        }
        let n_links = n_joints + 1;
        let goal = a.goal_heading_deg.to_radians();
        Self {
            wave,
            method: config.control.method,
            pids: vec![joint_pid(config); n_joints],
            dt_secs: config.general.timestep_secs,
            contacts: ContactFeed::new(config, a.contacts, n_links),
            heading: HeadingHold::for_law(
                config,
                n_joints,
                a.heading_gain,
                a.heading_max_offset_deg,
                a.goal_heading_deg,
            ),
            feedback: a.feedback,
            goal: [goal.cos(), goal.sin()],
            window,
            stiffness_nm_per_rad: a.stiffness_nm_per_rad,
            damping_nm_s_per_rad: a.damping_nm_s_per_rad,
            min_amplitude_rad: a.min_amplitude_deg.to_radians(),
            max_amplitude_rad: a.max_amplitude_deg.to_radians(),
            wedge_force_n: a.wedge_force_n,
            wedge_speed_m_per_s: a.wedge_speed_m_per_s,
            wedge_secs: a.wedge_secs,
            filter_secs: a.filter_secs,
            escape_stiffness_ratio: a.escape_stiffness_ratio,
            escape_secs: a.escape_secs,
            body: PlanarBody::new(n_links, config.snake.link_length_m, yaw_joints(config, n_joints)),
            amplitude_rad: vec![wave.amplitude_rad; windows],
            generalised_force_nm: vec![0.0; windows],
            torque_nm: vec![0.0; n_joints],
            base_rad: vec![0.0; n_joints],
            base_velocity_rad_per_s: vec![0.0; n_joints],
            resist_n: 0.0,
            speed_m_per_s: 0.0,
            last_com_m: None,
            wedged_since_secs: None,
            escape_until_secs: f64::NEG_INFINITY,
        }
    }

    /// Each window's amplitude βʷ (rad).
    pub fn amplitudes_rad(&self) -> &[f64] {
        &self.amplitude_rad
    }

    /// Each window's generalised force Fʷ of the last update (N·m).
    pub fn generalised_forces_nm(&self) -> &[f64] {
        &self.generalised_force_nm
    }

    /// Whether the escape mode (after a wedge) is on at `t_secs`.
    pub fn escaping(&self, t_secs: f64) -> bool {
        t_secs < self.escape_until_secs
    }

    fn step(&mut self, obs: &Observation, contacts: &ContactEstimates, cmd: &mut Command) {
        let t = obs.time_secs;
        if let Some(h) = self.heading.as_mut() {
            self.wave.offset_rad = h.wave_offset_rad(obs);
        }
        self.wave.targets(t, &mut self.base_rad, &mut self.base_velocity_rad_per_s);
        let n = self.base_rad.len();
        let omega = std::f64::consts::TAU * self.wave.frequency_hz;
        let (r, _) = super::gait::ramp(t, self.wave.ramp_secs);
        if self.feedback {
            let dt = self.body.sense(obs);
            let escaping = self.escaping(t);
            // τ = Jᵀf over the contacts complied to, and the resisting force against the goal.
            self.torque_nm.iter_mut().for_each(|x| *x = 0.0);
            let mut resist = 0.0;
            if contacts.active {
                for i in 0..self.body.n_links().min(contacts.contact.len()) {
                    if !contacts.contact[i] {
                        continue;
                    }
                    let f = [contacts.obstacle_force_n[i][0], contacts.obstacle_force_n[i][1]];
                    let side = flank(f, self.goal);
                    if side == Some(Flank::Resisting) {
                        resist -= f[0] * self.goal[0] + f[1] * self.goal[1];
                    }
                    if escaping || side == Some(Flank::Resisting) {
                        let p = self.body.contact_point_m(contacts, i);
                        self.body.add_joint_torques(i, p, f, &mut self.torque_nm);
                    }
                }
            }
            // Filters and the wedge rule.
            if dt > 0.0 {
                let k = low_pass_gain(dt, self.filter_secs);
                self.resist_n += k * (resist - self.resist_n);
                if let Some(last) = self.last_com_m {
                    let v = ((self.body.com_m[0] - last[0]) * self.goal[0]
                        + (self.body.com_m[1] - last[1]) * self.goal[1])
                        / dt;
                    self.speed_m_per_s += k * (v - self.speed_m_per_s);
                }
            }
            self.last_com_m = Some(self.body.com_m);
            let wedged = self.resist_n > self.wedge_force_n && self.speed_m_per_s < self.wedge_speed_m_per_s;
            if wedged && !escaping && self.escape_secs > 0.0 {
                let since = *self.wedged_since_secs.get_or_insert(t);
                if t - since >= self.wedge_secs {
                    self.escape_until_secs = t + self.escape_secs;
                    self.wedged_since_secs = None;
                }
            } else {
                self.wedged_since_secs = None;
            }
            let stiffness = self.stiffness_nm_per_rad * if escaping { self.escape_stiffness_ratio } else { 1.0 };
            // Fʷ and the admittance, one explicit Euler step (stable for dt < B/K).
            for (w, row) in self.window.iter().enumerate() {
                let mut f = 0.0;
                for (j, (g, tau)) in row.iter().zip(&self.torque_nm).enumerate() {
                    f += r * g * (omega * t - j as f64 * self.wave.phase_lag_rad).sin() * tau;
                }
                self.generalised_force_nm[w] = f;
                let beta = &mut self.amplitude_rad[w];
                let rate = (f - stiffness * (*beta - self.wave.amplitude_rad)) / self.damping_nm_s_per_rad;
                *beta = (*beta + dt * rate).clamp(self.min_amplitude_rad, self.max_amplitude_rad);
            }
        }
        for j in 0..n {
            let mut delta = 0.0;
            for (w, row) in self.window.iter().enumerate() {
                delta += row[j] * (self.amplitude_rad[w] - self.wave.amplitude_rad);
            }
            let angle = if delta == 0.0 {
                self.base_rad[j]
            } else {
                self.base_rad[j] + r * (omega * t - j as f64 * self.wave.phase_lag_rad).sin() * delta
            };
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

impl Controller for DirectionalAdmittance {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
        self.body.reset();
        let a = self.wave.amplitude_rad;
        self.amplitude_rad.iter_mut().for_each(|x| *x = a);
        self.generalised_force_nm.iter_mut().for_each(|x| *x = 0.0);
        self.resist_n = 0.0;
        self.speed_m_per_s = 0.0;
        self.last_com_m = None;
        self.wedged_since_secs = None;
        self.escape_until_secs = f64::NEG_INFINITY;
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
        c.control.controller = ControllerKind::DirectionalAdmittance;
        c.gait.kind = GaitKind::SineWave;
        c.gait.sine_wave.amplitude_deg = 60.0;
        c.gait.sine_wave.phase_lag_deg = 30.0;
        c.gait.ramp_secs = 0.0;
        c.estimation.enabled = true;
        c
    }

    /// A straight body along +x at time `t` with a contact on link 8 (tail window) from a peg on
    /// its left (force −y) with the given x component.
    fn observation(t: f64, force_x_n: f64) -> Observation {
        let mut obs = Observation::new(10, 9);
        obs.time_secs = t;
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.contacts = ContactEstimates::new(10);
        obs.contacts.active = true;
        obs.contacts.contact[8] = true;
        obs.contacts.obstacle_force_n[8] = [force_x_n, -5.0, 0.0];
        obs
    }

    #[test]
    fn windows_are_a_partition_of_unity() {
        let ctl = DirectionalAdmittance::from_config(&config(), 9);
        for j in 0..9 {
            let s: f64 = ctl.window.iter().map(|row| row[j]).sum();
            assert!((s - 1.0).abs() < 1e-12);
        }
        // The tail window weighs the tail joints most.
        assert!(ctl.window[2][8] > ctl.window[0][8]);
    }

    #[test]
    fn only_a_resisting_contact_moves_the_amplitudes() {
        let c = config();
        let dt = c.general.timestep_secs;
        // t such that the joints near the tail are bent (sin φⱼ ≠ 0).
        let t0 = 0.3;
        let mut cmd = Command::new(9);
        let mut propelled = DirectionalAdmittance::from_config(&c, 9);
        let mut resisted = DirectionalAdmittance::from_config(&c, 9);
        for k in 0..200 {
            propelled.update(&observation(t0 + k as f64 * dt, 1.0), &mut cmd);
            resisted.update(&observation(t0 + k as f64 * dt, -1.0), &mut cmd);
        }
        let a = c.gait.sine_wave.amplitude_deg.to_radians();
        assert!(propelled.amplitudes_rad().iter().all(|b| *b == a), "{:?}", propelled.amplitudes_rad());
        assert!(resisted.amplitudes_rad().iter().any(|b| (b - a).abs() > 1e-4), "{:?}", resisted.amplitudes_rad());
        // The admittance moves βʷ along Fʷ: each window's change has the sign of its force.
        for (b, f) in resisted.amplitudes_rad().iter().zip(resisted.generalised_forces_nm()) {
            if f.abs() > 1e-9 {
                assert_eq!((b - a).signum(), f.signum(), "β − A = {}, F = {f}", b - a);
            }
        }
    }

    #[test]
    fn the_amplitude_settles_at_a_plus_f_over_k() {
        // A constant generalised force F: B·β̇ = F − K(β − A) settles at β = A + F/K. Hold the
        // phase still (f = 0 Hz is not a sine wave: use a tiny frequency and a short window).
        let mut c = config();
        c.gait.sine_wave.frequency_hz = 1e-9;
        c.gait.sine_wave.phase_lag_deg = 90.0;
        c.directional_admittance.windows = 1;
        c.directional_admittance.escape_secs = 0.0;
        let mut ctl = DirectionalAdmittance::from_config(&c, 9);
        let mut cmd = Command::new(9);
        let dt = c.general.timestep_secs;
        for k in 0..20_000 {
            ctl.update(&observation(k as f64 * dt, -1.0), &mut cmd);
        }
        let a = c.gait.sine_wave.amplitude_deg.to_radians();
        let f = ctl.generalised_forces_nm()[0];
        let k = c.directional_admittance.stiffness_nm_per_rad;
        assert!(f.abs() > 0.01, "{f}");
        assert!((ctl.amplitudes_rad()[0] - (a + f / k)).abs() < 1e-6, "{} vs {}", ctl.amplitudes_rad()[0], a + f / k);
    }

    #[test]
    fn a_wedge_switches_to_the_escape_mode() {
        let mut c = config();
        c.directional_admittance.wedge_force_n = 0.5;
        c.directional_admittance.wedge_secs = 0.5;
        let mut ctl = DirectionalAdmittance::from_config(&c, 9);
        let mut cmd = Command::new(9);
        let dt = c.general.timestep_secs;
        let mut switched = None;
        for k in 0..3000 {
            let t = k as f64 * dt;
            ctl.update(&observation(t, -2.0), &mut cmd);
            if switched.is_none() && ctl.escaping(t + dt) {
                switched = Some(t);
            }
        }
        // The filtered resisting force passes 0.5 N of 2 N after ln(4/3)·τ_f, then wedge_secs.
        let tau = c.directional_admittance.filter_secs;
        let expected = tau * (2.0f64 / 1.5).ln() + 0.5;
        let t = switched.expect("the escape mode comes on");
        assert!((t - expected).abs() < 0.01, "{t} vs {expected}");
    }

    #[test]
    fn without_feedback_it_is_the_sine_wave_bit_for_bit() {
        let mut c = config();
        c.directional_admittance.feedback = false;
        c.gait.ramp_secs = 1.0;
        let mut ctl = DirectionalAdmittance::from_config(&c, 9);
        let mut open = super::super::TrajectoryController::from_config(&c, 9);
        let (mut a, mut b) = (Command::new(9), Command::new(9));
        for k in 0..500 {
            let obs = observation(k as f64 * 0.003, -1.0);
            ctl.update(&obs, &mut a);
            open.update(&obs, &mut b);
            assert_eq!(a.position_rad, b.position_rad);
        }
    }
}

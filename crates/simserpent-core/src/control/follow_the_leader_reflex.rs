//! A decentralised follow-the-leader body with a local lateral-pressure reflex (Kano & Ishiguro).
//!
//! Sources: T. Kano, T. Sato, R. Kobayashi, A. Ishiguro, "Local reflexive mechanisms essential
//! for snakes' scaffold-based locomotion", *Bioinspiration & Biomimetics* 7 (2012) 046008;
//! T. Kano, A. Ishiguro, "Obstacles are beneficial to me! Scaffold-based locomotion of a
//! snake-like robot using decentralized control", IEEE/RSJ IROS 2013, 3273–3278. In their scheme
//! each segment's target curvature is the curvature of the segment in front a moment earlier
//! (the shape flows from head to tail, so the body follows the head), and a segment pressed
//! sideways by a scaffold bends so as to push on a scaffold that lies behind it (one that helps
//! propulsion) and gives way to one that does not.
//!
//! Here, on the `[gait.sine_wave]` wave qⱼᵇ(t) = r(t)·A·sin(ωt − jδ) (δ > 0, ω = 2πf), joint j's
//! set-point is qⱼ(t) = qⱼᵇ(t) + oⱼ(t) with the offset
//!
//! ```text
//!   oⱼ(t) = clamp( oⱼ₋₁(t − τ) + ½·(ρⱼ + ρⱼ₊₁), ±o_max ),   o₋₁ ≡ 0,   τ = δ/ω,
//!   ρᵢ = +σ_p·p̄ᵢ   if the filtered contact force f̄ᵢ on link i is propulsive (f̄ᵢ·g > 0),
//!   ρᵢ = −σ_r·p̄ᵢ   if it is resisting (f̄ᵢ·g < 0),  0 without a contact,
//! ```
//!
//! where p̄ᵢ = f̄ᵢ·nᵢ is the lateral force on link i (module [`super::contact_jacobian`]: +c·pᵢ on
//! the joints at both ends of link i bends the body around the peg) and τ the wave's delay from
//! one joint to the next, so the wave and the offsets travel down the body together (qⱼᵇ(t) =
//! qⱼ₋₁ᵇ(t − τ) once the ramp-in is over): a bend made at a peg stays with the wave as it passes
//! the peg. The body's only sensors are the ones Boa has: the contact estimates
//! (`[estimation]`) or, as a switch for comparison, the true contacts, the encoders and the
//! head's IMU. With `feedback = false` (or no contact) every offset is 0 and the set-points are
//! the sine wave's, bit for bit.

use super::contact_jacobian::{Flank, PlanarBody, flank};
use super::{
    Command, ContactFeed, Controller, HeadingHold, Observation, Pid, SineWave, command_joint, feel, joint_pid,
    low_pass_gain, yaw_joints,
};
use crate::config::{Config, ControlMethod};
use crate::control::JointTrajectory;
use crate::estimation::ContactEstimates;
use crate::state::Snapshot;

/// The controller of `control.controller = "follow_the_leader_reflex"`.
pub struct FollowTheLeaderReflex {
    wave: SineWave,
    /// The heading-hold term (`heading_gain` > 0), which sets the wave's offset.
    heading: Option<HeadingHold>,
    method: ControlMethod,
    pids: Vec<Pid>,
    dt_secs: f64,
    contacts: ContactFeed,
    feedback: bool,
    goal: [f64; 2],
    propulsive_gain_rad_per_n: f64,
    resisting_gain_rad_per_n: f64,
    force_filter_secs: f64,
    max_offset_rad: f64,
    body: PlanarBody,
    /// Filtered horizontal contact force per link (N).
    force_n: Vec<[f64; 2]>,
    /// Per joint: its offsets of the last `delay_steps` steps (ring buffer), newest at `head`.
    history_rad: Vec<f64>,
    delay_steps: usize,
    head: usize,
    /// This step's offsets and reflex terms.
    offset_rad: Vec<f64>,
    reflex_rad: Vec<f64>,
    base_rad: Vec<f64>,
    base_velocity_rad_per_s: Vec<f64>,
}

impl FollowTheLeaderReflex {
    /// The controller of `config` for `n_joints` joints (validation requires the sine wave with
    /// δ > 0 when this controller is selected).
    pub fn from_config(config: &Config, n_joints: usize) -> Self {
        let r = &config.follow_the_leader_reflex;
        let w = &config.gait.sine_wave;
        let wave = SineWave::from_config(config);
        let dt = config.general.timestep_secs;
        // τ = δ/ω in steps (at least one step).
        let tau_secs =
            if w.frequency_hz > 0.0 { wave.phase_lag_rad / (std::f64::consts::TAU * w.frequency_hz) } else { 0.0 };
        let delay_steps = ((tau_secs / dt).round() as usize).max(1);
        let n_links = n_joints + 1;
        let goal = r.goal_heading_deg.to_radians();
        Self {
            wave,
            method: config.control.method,
            pids: vec![joint_pid(config); n_joints],
            dt_secs: dt,
            contacts: ContactFeed::new(config, r.contacts, n_links),
            heading: HeadingHold::for_law(
                config,
                n_joints,
                r.heading_gain,
                r.heading_max_offset_deg,
                r.goal_heading_deg,
            ),
            feedback: r.feedback,
            goal: [goal.cos(), goal.sin()],
            propulsive_gain_rad_per_n: r.propulsive_gain_rad_per_n,
            resisting_gain_rad_per_n: r.resisting_gain_rad_per_n,
            force_filter_secs: r.force_filter_secs,
            max_offset_rad: r.max_offset_deg.to_radians(),
            body: PlanarBody::new(n_links, config.snake.link_length_m, yaw_joints(config, n_joints)),
            force_n: vec![[0.0; 2]; n_links],
            history_rad: vec![0.0; n_joints * delay_steps],
            delay_steps,
            head: 0,
            offset_rad: vec![0.0; n_joints],
            reflex_rad: vec![0.0; n_joints],
            base_rad: vec![0.0; n_joints],
            base_velocity_rad_per_s: vec![0.0; n_joints],
        }
    }

    /// The joint offsets of the last update (rad).
    pub fn offsets_rad(&self) -> &[f64] {
        &self.offset_rad
    }

    /// The reflex terms ½·(ρⱼ + ρⱼ₊₁) of the last update (rad), before the offsets they feed.
    pub fn reflex_rad(&self) -> &[f64] {
        &self.reflex_rad
    }

    fn step(&mut self, obs: &Observation, contacts: &ContactEstimates, cmd: &mut Command) {
        let n = self.offset_rad.len();
        if let Some(h) = self.heading.as_mut() {
            self.wave.offset_rad = h.wave_offset_rad(obs);
        }
        self.wave.targets(obs.time_secs, &mut self.base_rad, &mut self.base_velocity_rad_per_s);
        if self.feedback {
            let dt = self.body.sense(obs);
            let k = if dt > 0.0 { low_pass_gain(dt, self.force_filter_secs) } else { 1.0 };
            // Filtered contact force per link; ρᵢ from its flank.
            for i in 0..self.force_n.len() {
                let raw = if contacts.active && contacts.contact.get(i).copied().unwrap_or(false) {
                    let f = contacts.obstacle_force_n[i];
                    [f[0], f[1]]
                } else {
                    [0.0; 2]
                };
                let f = &mut self.force_n[i];
                f[0] += k * (raw[0] - f[0]);
                f[1] += k * (raw[1] - f[1]);
            }
            let rho = |s: &Self, i: usize| -> f64 {
                let f = s.force_n[i];
                let nrm = s.body.normal(i);
                let p = f[0] * nrm[0] + f[1] * nrm[1];
                match flank(f, s.goal) {
                    Some(Flank::Propulsive) => s.propulsive_gain_rad_per_n * p,
                    Some(Flank::Resisting) => -s.resisting_gain_rad_per_n * p,
                    None => 0.0,
                }
            };
            // The oldest stored offsets are those of τ ago: read them before overwriting.
            let next = (self.head + 1) % self.delay_steps;
            for j in 0..n {
                let reflex = if self.body.is_yaw_joint(j) { 0.5 * (rho(self, j) + rho(self, j + 1)) } else { 0.0 };
                self.reflex_rad[j] = reflex;
                let from_front = if j == 0 { 0.0 } else { self.history_rad[(j - 1) * self.delay_steps + next] };
                self.offset_rad[j] = (from_front + reflex).clamp(-self.max_offset_rad, self.max_offset_rad);
            }
            for j in 0..n {
                self.history_rad[j * self.delay_steps + next] = self.offset_rad[j];
            }
            self.head = next;
        }
        for j in 0..n {
            let angle = self.base_rad[j] + self.offset_rad[j];
            let velocity = self.base_velocity_rad_per_s[j];
            command_joint(self.method, cmd, j, angle, velocity, obs, &mut self.pids[j], self.dt_secs);
        }
    }
}

impl Controller for FollowTheLeaderReflex {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
        self.body.reset();
        self.force_n.iter_mut().for_each(|f| *f = [0.0; 2]);
        self.history_rad.iter_mut().for_each(|x| *x = 0.0);
        self.offset_rad.iter_mut().for_each(|x| *x = 0.0);
        self.reflex_rad.iter_mut().for_each(|x| *x = 0.0);
        self.head = 0;
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
        c.control.controller = ControllerKind::FollowTheLeaderReflex;
        c.gait.kind = GaitKind::SineWave;
        c.gait.sine_wave.amplitude_deg = 30.0;
        c.gait.sine_wave.phase_lag_deg = 30.0;
        c.gait.ramp_secs = 0.0;
        c.follow_the_leader_reflex.force_filter_secs = 0.0;
        c.estimation.enabled = true;
        c
    }

    /// A straight body along +x (head tip at the origin) at time `t`, with a 5-N contact on
    /// link 3 (centre x = −0.7) from a peg on its left (the force points −y) with the given x
    /// component.
    fn observation(t: f64, force_x_n: f64) -> Observation {
        let mut obs = Observation::new(10, 9);
        obs.time_secs = t;
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.contacts = ContactEstimates::new(10);
        obs.contacts.active = true;
        obs.contacts.contact[3] = true;
        obs.contacts.obstacle_force_n[3] = [force_x_n, -5.0, 0.0];
        obs
    }

    #[test]
    fn a_propulsive_peg_is_wrapped_and_a_resisting_one_released() {
        let c = config();
        let gain = c.follow_the_leader_reflex.propulsive_gain_rad_per_n;
        let mut cmd = Command::new(9);
        // Propulsive (the force has +x): the joints at both ends of link 3 (2 and 3) bend by
        // +σ·p/2 each with p = f·n = −5 N (peg on the left): negative, around the peg.
        let mut ctl = FollowTheLeaderReflex::from_config(&c, 9);
        ctl.update(&observation(0.0, 1.0), &mut cmd);
        let expected = 0.5 * gain * -5.0;
        assert!((ctl.reflex_rad()[2] - expected).abs() < 1e-12, "{:?}", ctl.reflex_rad());
        assert!((ctl.reflex_rad()[3] - expected).abs() < 1e-12);
        assert!(ctl.reflex_rad().iter().enumerate().all(|(j, r)| j == 2 || j == 3 || *r == 0.0));
        // Resisting (−x): the same joints bend the other way, away from the peg.
        let mut ctl = FollowTheLeaderReflex::from_config(&c, 9);
        ctl.update(&observation(0.0, -1.0), &mut cmd);
        let g_r = c.follow_the_leader_reflex.resisting_gain_rad_per_n;
        assert!((ctl.reflex_rad()[2] - 0.5 * g_r * 5.0).abs() < 1e-12, "{:?}", ctl.reflex_rad());
        // The set-point is the wave plus the offset.
        let w = &c.gait.sine_wave;
        let base = w.amplitude_deg.to_radians() * (-2.0 * w.phase_lag_deg.to_radians()).sin();
        assert!((cmd.position_rad[2] - (base + ctl.offsets_rad()[2])).abs() < 1e-12);
    }

    #[test]
    fn an_offset_travels_one_joint_back_per_wave_delay() {
        let c = config();
        let dt = c.general.timestep_secs;
        let tau = c.gait.sine_wave.phase_lag_deg / 360.0 / c.gait.sine_wave.frequency_hz;
        let steps = (tau / dt).round() as usize;
        let mut ctl = FollowTheLeaderReflex::from_config(&c, 9);
        let mut cmd = Command::new(9);
        // One step of contact, then none: joint 3's reflex reaches joint 4 τ later, joint 5 2τ.
        ctl.update(&observation(0.0, 1.0), &mut cmd);
        let first = ctl.offsets_rad()[3];
        assert!(first < 0.0);
        let mut free = observation(0.0, 0.0);
        free.contacts.contact[3] = false;
        let mut seen = vec![];
        for k in 1..=2 * steps {
            free.time_secs = k as f64 * dt;
            ctl.update(&free, &mut cmd);
            seen.push((ctl.offsets_rad()[3], ctl.offsets_rad()[4], ctl.offsets_rad()[5]));
        }
        assert_eq!(seen[steps - 1].1, first, "joint 4 τ later");
        assert_eq!(seen[steps - 2].1, 0.0);
        assert_eq!(seen[2 * steps - 1].2, first, "joint 5 2τ later");
        assert_eq!(seen[0].0, 0.0, "joint 3's own offset ends with its contact");
    }

    /// During the gait's ramp-in the contacts do not feed the law (`control::feel`): the same
    /// contact moves the joints only from `gait.ramp_secs` on.
    #[test]
    fn contacts_feed_the_reflex_only_after_the_ramp_in() {
        let mut c = config();
        c.gait.ramp_secs = 1.0;
        let mut ctl = FollowTheLeaderReflex::from_config(&c, 9);
        let mut cmd = Command::new(9);
        ctl.update(&observation(0.999, 1.0), &mut cmd);
        assert!(ctl.reflex_rad().iter().all(|r| *r == 0.0), "{:?}", ctl.reflex_rad());
        ctl.update(&observation(1.0, 1.0), &mut cmd);
        assert!(ctl.reflex_rad()[2] < 0.0, "{:?}", ctl.reflex_rad());
    }

    /// The heading hold adds φ₀ = k·(θ̄ − θ_goal) to the wave's offset, with the feedback on or
    /// off: a straight body yawed 4° left of the goal, gain 0.5, gets +2° on every joint.
    #[test]
    fn the_heading_hold_adds_its_offset_to_every_joint() {
        let mut c = config();
        c.follow_the_leader_reflex.feedback = false;
        c.follow_the_leader_reflex.heading_gain = 0.5;
        let mut ctl = FollowTheLeaderReflex::from_config(&c, 9);
        let mut open = super::super::TrajectoryController::from_config(&c, 9);
        let (mut a, mut b) = (Command::new(9), Command::new(9));
        let mut obs = observation(0.7, 0.0);
        obs.contacts.contact[3] = false;
        let yaw = 4f64.to_radians();
        obs.head_quat = [(0.5 * yaw).cos(), 0.0, 0.0, (0.5 * yaw).sin()];
        ctl.update(&obs, &mut a);
        open.update(&obs, &mut b);
        for j in 0..9 {
            assert!((a.position_rad[j] - b.position_rad[j] - 2f64.to_radians()).abs() < 1e-12, "joint {j}");
        }
    }

    #[test]
    fn without_feedback_it_is_the_sine_wave_bit_for_bit() {
        let mut c = config();
        c.follow_the_leader_reflex.feedback = false;
        c.gait.ramp_secs = 1.0;
        let mut ctl = FollowTheLeaderReflex::from_config(&c, 9);
        let mut open = super::super::TrajectoryController::from_config(&c, 9);
        let (mut a, mut b) = (Command::new(9), Command::new(9));
        for k in 0..500 {
            let obs = observation(k as f64 * 0.003, 1.0);
            ctl.update(&obs, &mut a);
            open.update(&obs, &mut b);
            assert_eq!(a.position_rad, b.position_rad);
        }
    }
}

//! Path following: line-of-sight guidance with heading control through the joint offset.
//!
//! Source: P. Liljebäck, I. U. Haugstuen and K. Y. Pettersen, *Path following control of planar
//! snake robots using a cascaded approach*, IEEE Trans. Control Systems Technology 20(1),
//! 111–126, 2012; and Liljebäck, Pettersen, Stavdahl and Gravdahl, *Snake Robots: Modelling,
//! Mechatronics, and Control*, Springer 2013, ch. 8.
//!
//! The joints follow lateral undulation with an offset,
//!
//! ```text
//! φ_j,ref(t) = r(t)·(α·sin(ω t − j δ) + φ₀),
//! ```
//!
//! (α, ω = 2πf, δ from `[gait.sine_wave]`, r(t) the ramp-in of `gait.ramp_secs`). The offset
//! steers: a constant φ₀ turns the snake at a rate proportional to it, so the heading controller
//! is
//!
//! ```text
//! φ₀ = clamp(k_θ·(θ̄ − θ_ref), ±φ₀,max),   θ_ref = ψ_path − arctan(e / Δ)
//! ```
//!
//! (the sign: a positive offset bends the body into an arc whose headings grow from head to
//! tail, and moving forward along it the snake turns clockwise, so a heading above the reference
//! needs a positive offset — checked in `tests/it/closed_loop.rs`), where θ̄ is the mean of the link headings (θ₀ the head's yaw, θᵢ = θᵢ₋₁ + qᵢ along the chain:
//! our joint angle is the child link's heading minus the parent's, Liljebäck's
//! φᵢ = θᵢ − θᵢ₊₁ with his links numbered from the tail), ψ_path the direction of the current
//! path segment, e the cross-track error of the centre of mass (positive to the left of the
//! path), and Δ the look-ahead distance (the line-of-sight law: aim at the point Δ ahead on the
//! path). Liljebäck's cascaded controller adds feed-forward terms in θ̇_ref and θ̈_ref to
//! this proportional law; with a look-ahead of several body lengths the reference changes slowly
//! and the proportional part dominates (their Eq. 41 with the derivative terms dropped).
//!
//! Waypoints: the path is the polyline through `path_following.waypoints_m`; the controller
//! follows segment k (from waypoint k to k+1) until the centre of mass comes within
//! `acceptance_radius_m` of waypoint k+1 or passes it along the segment, then segment k+1; the
//! last segment is followed beyond its end. Two points give one straight line.
//!
//! What the controller measures: the head's position and yaw (an external tracking system, as in
//! Liljebäck's experiments; `Observation::head_position_m`, `head_quat`) and the joint encoders;
//! the centre of mass and θ̄ follow from the chain (equal links of `snake.link_length_m`).

use super::gait::{SineWave, ramp};
use super::{
    Command, Controller, Observation, Pid, command_joint, joint_pid, planar_chain, wrap_angle_rad, yaw_joints,
};
use crate::config::{Config, ControlMethod};
use std::f64::consts::TAU;

/// The path-following controller (module documentation).
#[derive(Debug, Clone)]
pub struct PathFollowing {
    /// α (rad), ω (rad/s), δ (rad), ramp (s).
    pub amplitude_rad: f64,
    pub angular_frequency_rad_per_s: f64,
    pub phase_lag_rad: f64,
    pub ramp_secs: f64,
    /// Path points (world x, y; m).
    pub waypoints_m: Vec<[f64; 2]>,
    /// Δ (m).
    pub lookahead_m: f64,
    /// k_θ.
    pub heading_gain: f64,
    /// φ₀,max (rad).
    pub max_offset_rad: f64,
    /// Waypoint acceptance radius (m).
    pub acceptance_radius_m: f64,
    /// Link length (m).
    pub link_length_m: f64,
    /// Per joint: whether it turns about the vertical (yaw) axis and so steers.
    yaw_joint: Vec<bool>,
    /// θᵢ (rad), scratch.
    heading_rad: Vec<f64>,
    method: ControlMethod,
    pids: Vec<Pid>,
    dt_secs: f64,
    segment: usize,
    /// Latest guidance values, for logging and tests.
    pub last: Guidance,
}

/// The guidance of the latest update.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Guidance {
    /// Centre of mass (x, y; m) from the chain.
    pub centre_of_mass_m: [f64; 2],
    /// Cross-track error e (m), positive left of the path.
    pub cross_track_m: f64,
    /// θ̄ and θ_ref (rad).
    pub mean_heading_rad: f64,
    pub reference_heading_rad: f64,
    /// φ₀ (rad), before the ramp.
    pub offset_rad: f64,
    /// The segment followed (0 = from waypoint 0 to 1).
    pub segment: usize,
}

impl PathFollowing {
    /// The controller of `config` (`[path_following]`, `[gait.sine_wave]`, `[control]`) for
    /// `n_joints` joints.
    pub fn from_config(config: &Config, n_joints: usize) -> Self {
        let wave = SineWave::from_config(config);
        let p = &config.path_following;
        Self {
            amplitude_rad: wave.amplitude_rad,
            angular_frequency_rad_per_s: TAU * wave.frequency_hz,
            phase_lag_rad: wave.phase_lag_rad,
            ramp_secs: wave.ramp_secs,
            waypoints_m: p.waypoints_m.clone(),
            lookahead_m: p.lookahead_m,
            heading_gain: p.heading_gain,
            max_offset_rad: p.max_offset_deg.to_radians(),
            acceptance_radius_m: p.acceptance_radius_m,
            link_length_m: config.snake.link_length_m,
            yaw_joint: yaw_joints(config, n_joints),
            heading_rad: vec![0.0; n_joints + 1],
            method: config.control.method,
            pids: vec![joint_pid(config); n_joints],
            dt_secs: config.general.timestep_secs,
            segment: 0,
            last: Guidance::default(),
        }
    }

    /// Centre of mass (x, y) and mean link heading θ̄ from the head pose and the encoders.
    fn chain(&mut self, obs: &Observation) -> ([f64; 2], f64) {
        let yaw = crate::state::yaw_rad(obs.head_quat);
        let head = [obs.head_position_m[0], obs.head_position_m[1]];
        let (theta_mean, com) =
            planar_chain(yaw, head, &obs.joint_angle_rad, &self.yaw_joint, self.link_length_m, &mut self.heading_rad);
        (com, theta_mean)
    }

    /// The guidance for the centre of mass `p` and mean heading `theta_mean` (advances the
    /// waypoint segment when reached).
    pub fn guidance(&mut self, p: [f64; 2], theta_mean: f64) -> Guidance {
        let last_segment = self.waypoints_m.len().saturating_sub(2);
        loop {
            let (a, b) = (self.waypoints_m[self.segment], self.waypoints_m[self.segment + 1]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let len = d[0].hypot(d[1]);
            let along = ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len;
            let reached = (p[0] - b[0]).hypot(p[1] - b[1]) < self.acceptance_radius_m || along > len;
            if self.segment < last_segment && reached {
                self.segment += 1;
                continue;
            }
            let (ux, uy) = (d[0] / len, d[1] / len);
            let e = ux * (p[1] - a[1]) - uy * (p[0] - a[0]);
            let psi = uy.atan2(ux);
            let theta_ref = psi - (e / self.lookahead_m).atan();
            // A positive offset bends the body so that the headings grow from head to tail: moving
            // forward along that arc the snake turns clockwise (θ̄ decreases). So the offset has
            // the sign of θ̄ − θ_ref.
            let offset = (self.heading_gain * wrap_angle_rad(theta_mean - theta_ref))
                .clamp(-self.max_offset_rad, self.max_offset_rad);
            return Guidance {
                centre_of_mass_m: p,
                cross_track_m: e,
                mean_heading_rad: theta_mean,
                reference_heading_rad: theta_ref,
                offset_rad: offset,
                segment: self.segment,
            };
        }
    }
}

impl Controller for PathFollowing {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
        self.segment = 0;
        self.last = Guidance::default();
    }

    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        let (p, theta_mean) = self.chain(obs);
        let g = self.guidance(p, theta_mean);
        self.last = g;
        let t = obs.time_secs;
        let (r, dr) = ramp(t, self.ramp_secs);
        let omega = self.angular_frequency_rad_per_s;
        for j in 0..obs.joint_angle_rad.len().min(cmd.position_rad.len()) {
            let phase = omega * t - j as f64 * self.phase_lag_rad;
            let offset = if self.yaw_joint[j] { g.offset_rad } else { 0.0 };
            let shape = self.amplitude_rad * phase.sin() + offset;
            let angle = r * shape;
            let velocity = dr * shape + r * self.amplitude_rad * omega * phase.cos();
            command_joint(self.method, cmd, j, angle, velocity, obs, &mut self.pids[j], self.dt_secs);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn controller() -> PathFollowing {
        let mut c = Config::default();
        c.path_following.waypoints_m = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]];
        c.path_following.heading_gain = 0.5;
        c.path_following.lookahead_m = 1.0;
        PathFollowing::from_config(&c, 9)
    }

    #[test]
    fn line_of_sight_aims_back_at_the_path() {
        let mut pf = controller();
        // 1 m left of the path, heading along it: θ_ref = −atan(1/1) = −45°, offset = 0.5·(0 + π/4)
        // (positive: turn clockwise, back toward the path).
        let g = pf.guidance([1.0, 1.0], 0.0);
        assert!((g.cross_track_m - 1.0).abs() < 1e-12);
        assert!((g.reference_heading_rad + PI / 4.0).abs() < 1e-12);
        assert!((g.offset_rad - (0.5 * PI / 4.0).min(20f64.to_radians())).abs() < 1e-12, "{g:?}");
    }

    #[test]
    fn waypoints_switch_within_the_acceptance_radius() {
        let mut pf = controller();
        assert_eq!(pf.guidance([1.0, 0.0], 0.0).segment, 0);
        let g = pf.guidance([1.9, 0.1], 0.0);
        assert_eq!(g.segment, 1);
        // Segment 1 points along +y; x = 1.9 is 0.1 m to its left (−x is left of +y): e = +0.1.
        assert!((g.cross_track_m - 0.1).abs() < 1e-12, "{g:?}");
        // The last segment is followed beyond its end.
        assert_eq!(pf.guidance([2.0, 5.0], PI / 2.0).segment, 1);
    }

    #[test]
    fn chain_of_a_straight_snake_has_its_centre_half_a_body_behind_the_head() {
        let mut pf = controller();
        let mut obs = Observation::new(10, 9);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        let (p, theta) = pf.chain(&obs);
        assert!((p[0] + 1.0).abs() < 1e-12 && p[1].abs() < 1e-12 && theta.abs() < 1e-12, "{p:?}");
    }
}

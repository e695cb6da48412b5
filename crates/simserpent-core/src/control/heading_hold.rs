//! Heading hold: the gait's offset φ₀ steers the body's mean heading toward the goal.
//!
//! Source: P. Liljebäck, K. Y. Pettersen, Ø. Stavdahl, J. T. Gravdahl, *Snake Robots:
//! Modelling, Mechatronics, and Control*, Springer 2013, ch. 8 (the heading controller of the
//! line-of-sight path-following law; P. Liljebäck, I. U. Haugstuen, K. Y. Pettersen, IEEE TCST
//! 20(1), 2012, Eq. 41 without its feed-forward terms). A lateral-undulation wave with a joint
//! offset φ₀, φⱼ(t) = r(t)·(α·sin(ωt − jδ) + φ₀), turns the snake at a rate proportional to φ₀;
//! the proportional heading controller
//!
//! ```text
//!   φ₀ = clamp( k_θ·wrap(θ̄ − θ_goal), ±φ₀,max )
//! ```
//!
//! holds the mean link heading θ̄ at the goal direction θ_goal (the laws' `goal_heading_deg`). θ̄
//! is the mean of the link headings θ₀ = the head's yaw (`Observation::head_quat`, as a tracking
//! system or the head IMU gives it) and θᵢ = θᵢ₋₁ + qᵢ₋₁ over the yaw joints (the encoders;
//! [`super::planar_chain`]). The sign: a positive offset bends the body into an arc along which
//! the snake turns clockwise, so a heading left of the goal (θ̄ > θ_goal) needs a positive
//! offset (the same convention as [`super::PathFollowing`], checked in
//! `tests/it/closed_loop.rs`). With one wavelength on the body (the OAL benchmark's δ = 36° on
//! 10 links) θ̄ barely oscillates within a cycle, so no filter is needed.
//!
//! The contact laws (`follow_the_leader_reflex`, `directional_admittance`, `jam_resolution`) add
//! φ₀ to `gait.sine_wave.offset_deg` when their `heading_gain` is above 0; the term is
//! independent of their `feedback` switch (which turns the contact terms on and off), so a law
//! with feedback off and the heading hold on is the open loop with the same heading hold.

use super::{Observation, planar_chain, wrap_angle_rad, yaw_joints};
use crate::config::Config;

/// The heading-hold term (module documentation).
#[derive(Debug, Clone)]
pub struct HeadingHold {
    /// k_θ: offset (rad) per radian of heading error.
    pub gain: f64,
    /// φ₀,max (rad).
    pub max_offset_rad: f64,
    /// θ_goal (rad).
    pub goal_rad: f64,
    /// The wave's own offset `gait.sine_wave.offset_deg` (rad), to which φ₀ is added.
    pub base_offset_rad: f64,
    link_length_m: f64,
    yaw_joint: Vec<bool>,
    heading_rad: Vec<f64>,
    /// θ̄ of the last update (rad).
    pub mean_heading_rad: f64,
}

impl HeadingHold {
    /// The term for a chain of `yaw_joint.len() + 1` links of `link_length_m`; `None` when
    /// `gain` is 0 (no heading hold).
    pub fn new(
        gain: f64,
        max_offset_deg: f64,
        goal_heading_deg: f64,
        link_length_m: f64,
        yaw_joint: Vec<bool>,
    ) -> Option<Self> {
        (gain > 0.0).then(|| Self {
            gain,
            max_offset_rad: max_offset_deg.to_radians(),
            goal_rad: goal_heading_deg.to_radians(),
            base_offset_rad: 0.0,
            link_length_m,
            heading_rad: vec![0.0; yaw_joint.len() + 1],
            yaw_joint,
            mean_heading_rad: 0.0,
        })
    }

    /// A contact law's heading hold: its `heading_gain`, `heading_max_offset_deg` and
    /// `goal_heading_deg`, on `config`'s snake and sine wave with `n_joints` joints.
    pub fn for_law(
        config: &Config,
        n_joints: usize,
        gain: f64,
        max_offset_deg: f64,
        goal_heading_deg: f64,
    ) -> Option<Self> {
        let yaw = yaw_joints(config, n_joints);
        Self::new(gain, max_offset_deg, goal_heading_deg, config.snake.link_length_m, yaw)
            .map(|h| Self { base_offset_rad: config.gait.sine_wave.offset_deg.to_radians(), ..h })
    }

    /// The wave's offset with the heading hold: `gait.sine_wave.offset_deg` + φ₀ (rad).
    pub fn wave_offset_rad(&mut self, obs: &Observation) -> f64 {
        self.base_offset_rad + self.offset_rad(obs)
    }

    /// φ₀ (rad) for the observation's head yaw and joint angles.
    pub fn offset_rad(&mut self, obs: &Observation) -> f64 {
        let yaw = crate::state::yaw_rad(obs.head_quat);
        let (mean, _) = planar_chain(
            yaw,
            [0.0; 2],
            &obs.joint_angle_rad,
            &self.yaw_joint,
            self.link_length_m,
            &mut self.heading_rad,
        );
        self.mean_heading_rad = mean;
        (self.gain * wrap_angle_rad(mean - self.goal_rad)).clamp(-self.max_offset_rad, self.max_offset_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observation(yaw_rad: f64, joints_rad: &[f64]) -> Observation {
        let mut obs = Observation::new(joints_rad.len() + 1, joints_rad.len());
        obs.head_quat = [(0.5 * yaw_rad).cos(), 0.0, 0.0, (0.5 * yaw_rad).sin()];
        obs.joint_angle_rad.copy_from_slice(joints_rad);
        obs
    }

    #[test]
    fn the_offset_is_the_gain_times_the_mean_heading_error_clamped() {
        let mut h = HeadingHold::new(0.5, 8.0, 0.0, 0.1, vec![true; 3]).expect("gain > 0");
        // Straight body turned 4° left of the goal: φ₀ = 0.5 · 4° = 2°.
        let phi = h.offset_rad(&observation(4f64.to_radians(), &[0.0; 3]));
        assert!((phi - 2f64.to_radians()).abs() < 1e-12, "{phi}");
        // Joints 10° each: headings 4, 14, 24, 34 → mean 19°; 0.5 · 19° = 9.5° clamps at 8°.
        let phi = h.offset_rad(&observation(4f64.to_radians(), &[10f64.to_radians(); 3]));
        assert!((h.mean_heading_rad - 19f64.to_radians()).abs() < 1e-12);
        assert!((phi - 8f64.to_radians()).abs() < 1e-12, "{phi}");
        // Right of the goal: negative; the error wraps (goal 170°, heading −170° is 20° left).
        assert!(h.offset_rad(&observation(-4f64.to_radians(), &[0.0; 3])) < 0.0);
        let mut h = HeadingHold::new(0.5, 30.0, 170.0, 0.1, vec![true; 3]).expect("gain > 0");
        let phi = h.offset_rad(&observation(-170f64.to_radians(), &[0.0; 3]));
        assert!((phi - 10f64.to_radians()).abs() < 1e-9, "{}", phi.to_degrees());
    }

    #[test]
    fn pitch_joints_do_not_turn_the_heading_and_gain_zero_is_off() {
        let mut h = HeadingHold::new(1.0, 45.0, 0.0, 0.1, vec![false, true]).expect("gain > 0");
        h.offset_rad(&observation(0.0, &[0.3, 0.0]));
        assert_eq!(h.mean_heading_rad, 0.0);
        assert!(HeadingHold::new(0.0, 10.0, 0.0, 0.1, vec![true; 3]).is_none());
    }
}

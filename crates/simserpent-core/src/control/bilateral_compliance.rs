//! Generalised (directional and bidirectional) body compliance of a bilaterally actuated
//! undulator: a mechanical baseline without any contact sensing.
//!
//! Source: T. Wang, C. Pierce, V. Kojouharov, B. Chong, K. Diaz, H. Lu, D. I. Goldman,
//! "Mechanical intelligence simplifies control in terrestrial limbless locomotion", *Science
//! Robotics* 8 (2023) eadi2243. Their robot bends each joint with two cables, one per side; a
//! cable that is paid out beyond what the wave needs lets the joint be pushed that way freely,
//! and the *generalised compliance* G sets how far: G = 0 holds the joint on the wave
//! (bidirectionally non-compliant), 0 < G ≤ ½ lets it straighten toward 0 (directional
//! compliance: it yields to a peg that flattens the bend, not to one that deepens it), ½ < G ≤ 1
//! also lets it bend past the wave and through 0 (bidirectional compliance).
//!
//! Here, with the wave qⱼᵇ(t) = r(t)·(A·sin(ωt − jδ) + φ₀) of `[gait.sine_wave]`, joint j may
//! take any angle in the interval spanned by
//!
//! ```text
//!   0 ≤ G ≤ ½:  [ qⱼᵇ·(1 − 2G),  qⱼᵇ ]
//!   ½ < G ≤ 1:  [ −s·(2G − 1)·A,  qⱼᵇ + s·(2G − 1)·A ],   s = sign(qⱼᵇ)
//! ```
//!
//! (SimSerpent's reading of the cable lengths: the slack of the released cable grows linearly
//! with G, reaching the wave's full swing at G = 1). The position servo's set-point is the
//! measured joint angle clamped to that interval, so the servo pulls only when the joint leaves
//! it (inside, only its damping kv acts). G = 0 sends the sine wave's set-points, bit for bit.

use super::{Command, Controller, JointTrajectory, Observation, SineWave};
use crate::config::Config;

/// The admissible interval (lo, hi) of a joint whose wave angle is `wave_rad`, for amplitude
/// `amplitude_rad` and generalised compliance `g` ∈ [0, 1].
pub fn admissible_interval(wave_rad: f64, amplitude_rad: f64, g: f64) -> (f64, f64) {
    let g = g.clamp(0.0, 1.0);
    let (a, b) = if g <= 0.5 {
        (wave_rad * (1.0 - 2.0 * g), wave_rad)
    } else {
        let s = if wave_rad < 0.0 { -1.0 } else { 1.0 };
        let slack = s * (2.0 * g - 1.0) * amplitude_rad;
        (-slack, wave_rad + slack)
    };
    (a.min(b), a.max(b))
}

/// The base wave of `[gait.sine_wave]` with generalised compliance G.
pub struct BilateralCompliance {
    wave: SineWave,
    compliance: f64,
    wave_rad: Vec<f64>,
    wave_velocity_rad_per_s: Vec<f64>,
}

impl BilateralCompliance {
    /// For `n_joints` joints, the wave of `config.gait.sine_wave` (ramp `config.gait.ramp_secs`)
    /// and generalised compliance `compliance` (clamped to [0, 1]).
    pub fn new(config: &Config, n_joints: usize, compliance: f64) -> Self {
        Self {
            wave: SineWave::from_config(config),
            compliance: compliance.clamp(0.0, 1.0),
            wave_rad: vec![0.0; n_joints],
            wave_velocity_rad_per_s: vec![0.0; n_joints],
        }
    }
}

impl Controller for BilateralCompliance {
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        self.wave.targets(obs.time_secs, &mut self.wave_rad, &mut self.wave_velocity_rad_per_s);
        for (j, q) in cmd.position_rad.iter_mut().enumerate() {
            let (lo, hi) = admissible_interval(self.wave_rad[j], self.wave.amplitude_rad, self.compliance);
            *q = if self.compliance > 0.0 {
                obs.joint_angle_rad.get(j).copied().unwrap_or(self.wave_rad[j]).clamp(lo, hi)
            } else {
                self.wave_rad[j]
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_interval_grows_from_the_wave_to_both_sides() {
        let a = 0.7;
        // G = 0: the wave angle only.
        assert_eq!(admissible_interval(0.5, a, 0.0), (0.5, 0.5));
        // G = ¼: halfway to straight; G = ½: all the way to straight, never past the wave.
        assert_eq!(admissible_interval(0.5, a, 0.25), (0.25, 0.5));
        assert_eq!(admissible_interval(-0.5, a, 0.5), (-0.5, 0.0));
        // G = ¾: half the swing past both ends; G = 1: the full swing.
        let (lo, hi) = admissible_interval(0.5, a, 0.75);
        assert!((lo + 0.35).abs() < 1e-12 && (hi - 0.85).abs() < 1e-12, "{lo} {hi}");
        let (lo, hi) = admissible_interval(-0.5, a, 1.0);
        assert!((lo + 1.2).abs() < 1e-12 && (hi - 0.7).abs() < 1e-12, "{lo} {hi}");
    }

    #[test]
    fn set_points_hold_the_joint_inside_the_interval() {
        let mut c = Config::default();
        c.gait.ramp_secs = 0.0;
        let mut ctl = BilateralCompliance::new(&c, 3, 0.5);
        let mut obs = Observation::new(4, 3);
        let mut cmd = Command::new(3);
        obs.time_secs = 0.3;
        // A joint far past the wave is pulled to the interval's end; one inside is left alone.
        let mut wave = (vec![0.0; 3], vec![0.0; 3]);
        ctl.wave.targets(0.3, &mut wave.0, &mut wave.1);
        obs.joint_angle_rad = vec![wave.0[0] * 3.0, wave.0[1] * 0.5, -wave.0[2].signum() * 1.0];
        ctl.update(&obs, &mut cmd);
        assert_eq!(cmd.position_rad[0], wave.0[0]);
        assert_eq!(cmd.position_rad[1], wave.0[1] * 0.5);
        assert_eq!(cmd.position_rad[2], 0.0);
        // G = 0 is the sine wave.
        let mut stiff = BilateralCompliance::new(&c, 3, 0.0);
        stiff.update(&obs, &mut cmd);
        assert_eq!(cmd.position_rad, wave.0);
    }
}

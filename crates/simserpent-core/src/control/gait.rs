//! Joint trajectories: target angle and velocity per joint as functions of time.

use crate::config::{Config, GaitKind};
use std::f64::consts::TAU;

/// A joint-space trajectory: fills the target angle (rad) and its time derivative (rad/s) for
/// every joint at time `t_secs`. Implementations must not allocate.
pub trait JointTrajectory: Send {
    /// Writes targets for all joints (`angle_rad.len()` joints).
    fn targets(&self, t_secs: f64, angle_rad: &mut [f64], velocity_rad_per_s: &mut [f64]);
}

/// Smoothstep 3s² − 2s³ on [0, 1] and its derivative with respect to s.
fn smoothstep(s: f64) -> (f64, f64) {
    let s = s.clamp(0.0, 1.0);
    (s * s * (3.0 - 2.0 * s), 6.0 * s * (1.0 - s))
}

/// Amplitude ramp r(t) in [0, 1] and dr/dt: smooth from 0 at t = 0 to 1 at `ramp_secs`.
pub(crate) fn ramp(t_secs: f64, ramp_secs: f64) -> (f64, f64) {
    if ramp_secs <= 0.0 || t_secs >= ramp_secs {
        return (1.0, 0.0);
    }
    let (r, dr_ds) = smoothstep(t_secs / ramp_secs);
    (r, dr_ds / ramp_secs)
}

/// All joints held at zero.
#[derive(Debug, Clone, Copy, Default)]
pub struct Still;

impl JointTrajectory for Still {
    fn targets(&self, _t_secs: f64, angle_rad: &mut [f64], velocity_rad_per_s: &mut [f64]) {
        angle_rad.fill(0.0);
        velocity_rad_per_s.fill(0.0);
    }
}

/// All joints held at fixed angles (rad; joints beyond the list at zero): `gait.kind = "none"`
/// with `initial_state.joint_angles_deg`, so that the snake keeps the shape it starts in.
#[derive(Debug, Clone, Default)]
pub struct Hold {
    /// The angle of each joint (rad), joint_01 first.
    pub angles_rad: Vec<f64>,
}

impl JointTrajectory for Hold {
    fn targets(&self, _t_secs: f64, angle_rad: &mut [f64], velocity_rad_per_s: &mut [f64]) {
        angle_rad.fill(0.0);
        for (a, held) in angle_rad.iter_mut().zip(&self.angles_rad) {
            *a = *held;
        }
        velocity_rad_per_s.fill(0.0);
    }
}

/// The sinusoidal joint wave (thesis "do_sinus"; lateral undulation):
/// φ_j(t) = r(t)·(A·sin(2πf·t − j·δ) + φ₀), j = 0 for the joint right behind the head, so that
/// with δ > 0 the wave travels from head to tail. r(t) is the smooth ramp-in.
#[derive(Debug, Clone, Copy)]
pub struct SineWave {
    /// A (rad).
    pub amplitude_rad: f64,
    /// f (Hz).
    pub frequency_hz: f64,
    /// δ (rad).
    pub phase_lag_rad: f64,
    /// φ₀ (rad): a constant offset that makes the snake turn.
    pub offset_rad: f64,
    /// Ramp-in time (s).
    pub ramp_secs: f64,
}

impl SineWave {
    /// The wave of `config.gait.sine_wave` with the ramp-in `config.gait.ramp_secs` (whatever
    /// `config.gait.kind` says: the controllers that shape the sine wave start from it).
    pub fn from_config(config: &Config) -> Self {
        let w = &config.gait.sine_wave;
        Self {
            amplitude_rad: w.amplitude_deg.to_radians(),
            frequency_hz: w.frequency_hz,
            phase_lag_rad: w.phase_lag_deg.to_radians(),
            offset_rad: w.offset_deg.to_radians(),
            ramp_secs: config.gait.ramp_secs,
        }
    }
}

impl JointTrajectory for SineWave {
    fn targets(&self, t_secs: f64, angle_rad: &mut [f64], velocity_rad_per_s: &mut [f64]) {
        let (r, dr) = ramp(t_secs, self.ramp_secs);
        let omega = TAU * self.frequency_hz;
        for (j, (angle, velocity)) in angle_rad.iter_mut().zip(velocity_rad_per_s.iter_mut()).enumerate() {
            let phase = omega * t_secs - j as f64 * self.phase_lag_rad;
            let shape = self.amplitude_rad * phase.sin() + self.offset_rad;
            *angle = r * shape;
            *velocity = dr * shape + r * self.amplitude_rad * omega * phase.cos();
        }
    }
}

/// The thesis' form-closure motion (chapter 7.4): a cyclic list of joint angles that moves one
/// place toward the tail every `shift_period_secs`, blended smoothly (smoothstep) between
/// places. At t = 0 joint j has `pattern_rad[j % len]`, the shape the snake starts in.
#[derive(Debug, Clone)]
pub struct FormClosureShift {
    /// The cyclic pattern (rad).
    pub pattern_rad: Vec<f64>,
    /// Time per shift (s).
    pub shift_period_secs: f64,
}

impl JointTrajectory for FormClosureShift {
    fn targets(&self, t_secs: f64, angle_rad: &mut [f64], velocity_rad_per_s: &mut [f64]) {
        let len = self.pattern_rad.len();
        if len == 0 || self.shift_period_secs <= 0.0 {
            return Still.targets(t_secs, angle_rad, velocity_rad_per_s);
        }
        let u = (t_secs / self.shift_period_secs).max(0.0);
        let k = u.floor();
        let (b, db_du) = smoothstep(u - k);
        let shift = (k as usize) % len;
        for (j, (angle, velocity)) in angle_rad.iter_mut().zip(velocity_rad_per_s.iter_mut()).enumerate() {
            // Joint j now shows what joint j - shift showed at t = 0 (the list moved toward the tail).
            let current = self.pattern_rad[(j + len - shift % len) % len];
            let next = self.pattern_rad[(j + 2 * len - shift - 1) % len];
            *angle = current + b * (next - current);
            *velocity = (next - current) * db_du / self.shift_period_secs;
        }
    }
}

/// Hirose's serpenoid curve discretised over N links (Hirose, *Biologically Inspired Robots*,
/// 1993; as used by Saito et al., IEEE Control Systems 2002): joint j (0 = behind the head)
/// follows φ_j = r(t)·(2a·sin(Kπ/N)·sin(2πf·t − 2Kπ·j/N) + φ₀), where a is the winding angle,
/// K the number of waves along the body and r(t) the ramp-in. It is the sine wave with amplitude
/// 2a·sin(Kπ/N) and phase lag 2Kπ/N, so the body takes K full S-shapes whatever N is.
pub fn serpenoid(
    winding_angle_rad: f64,
    n_waves: f64,
    n_links: usize,
    frequency_hz: f64,
    offset_rad: f64,
    ramp_secs: f64,
) -> SineWave {
    let n = n_links.max(1) as f64;
    SineWave {
        amplitude_rad: 2.0 * winding_angle_rad * (std::f64::consts::PI * n_waves / n).sin(),
        frequency_hz,
        phase_lag_rad: TAU * n_waves / n,
        offset_rad,
        ramp_secs,
    }
}

/// Gaits of snakes whose joints alternate yaw and pitch (joint 0 yaw, joint 1 pitch, …): one
/// travelling wave on the yaw joints and one on the pitch joints.
/// - Sidewinding: yaw joint j: A_y·sin(ωt − j·δ), pitch joint j: A_p·sin(ωt − j·δ + φ_p), with
///   φ_p ≈ 90° (Hatton and Choset's two-wave model); the body lifts where it moves and rests
///   where it pushes, so it moves sideways.
/// - Rolling: every yaw joint A·sin(ωt), every pitch joint A·cos(ωt): the body is an arc whose
///   plane turns about the body axis, so it rolls sideways (δ = 0, φ_p = 90°).
#[derive(Debug, Clone, Copy)]
pub struct TwoPlaneWave {
    /// Amplitude of the yaw joints (rad).
    pub yaw_amplitude_rad: f64,
    /// Amplitude of the pitch joints (rad).
    pub pitch_amplitude_rad: f64,
    /// f (Hz).
    pub frequency_hz: f64,
    /// δ per joint (rad).
    pub phase_lag_rad: f64,
    /// Phase of the pitch wave relative to the yaw wave (rad).
    pub pitch_phase_rad: f64,
    /// Ramp-in time (s).
    pub ramp_secs: f64,
}

impl JointTrajectory for TwoPlaneWave {
    fn targets(&self, t_secs: f64, angle_rad: &mut [f64], velocity_rad_per_s: &mut [f64]) {
        let (r, dr) = ramp(t_secs, self.ramp_secs);
        let omega = TAU * self.frequency_hz;
        for (j, (angle, velocity)) in angle_rad.iter_mut().zip(velocity_rad_per_s.iter_mut()).enumerate() {
            let (amplitude, extra) = if j % 2 == 0 {
                (self.yaw_amplitude_rad, 0.0)
            } else {
                (self.pitch_amplitude_rad, self.pitch_phase_rad)
            };
            let phase = omega * t_secs - j as f64 * self.phase_lag_rad + extra;
            let shape = amplitude * phase.sin();
            *angle = r * shape;
            *velocity = dr * shape + r * amplitude * omega * phase.cos();
        }
    }
}

/// The trajectory that `config.gait` describes.
pub fn trajectory_from_config(config: &Config) -> Box<dyn JointTrajectory> {
    let gait = &config.gait;
    match gait.kind {
        GaitKind::None if config.initial_state.joint_angles_deg.is_empty() => Box::new(Still),
        GaitKind::None => Box::new(Hold {
            angles_rad: config.initial_state.joint_angles_deg.iter().map(|a| a.to_radians()).collect(),
        }),
        GaitKind::SineWave => Box::new(SineWave::from_config(config)),
        GaitKind::Serpenoid => {
            let sp = &gait.serpenoid;
            Box::new(serpenoid(
                sp.winding_angle_deg.to_radians(),
                sp.n_waves,
                config.snake.n_links,
                sp.frequency_hz,
                sp.offset_deg.to_radians(),
                gait.ramp_secs,
            ))
        }
        GaitKind::Sidewinding => {
            let sw = &gait.sidewinding;
            Box::new(TwoPlaneWave {
                yaw_amplitude_rad: sw.yaw_amplitude_deg.to_radians(),
                pitch_amplitude_rad: sw.pitch_amplitude_deg.to_radians(),
                frequency_hz: sw.frequency_hz,
                phase_lag_rad: sw.phase_lag_deg.to_radians(),
                pitch_phase_rad: sw.pitch_phase_deg.to_radians(),
                ramp_secs: gait.ramp_secs,
            })
        }
        GaitKind::Rolling => Box::new(TwoPlaneWave {
            yaw_amplitude_rad: gait.rolling.amplitude_deg.to_radians(),
            pitch_amplitude_rad: gait.rolling.amplitude_deg.to_radians(),
            frequency_hz: gait.rolling.frequency_hz,
            phase_lag_rad: 0.0,
            pitch_phase_rad: std::f64::consts::FRAC_PI_2,
            ramp_secs: gait.ramp_secs,
        }),
        GaitKind::FormClosure => Box::new(FormClosureShift {
            pattern_rad: gait.form_closure.pattern_deg.iter().map(|d| d.to_radians()).collect(),
            shift_period_secs: gait.form_closure.shift_period_secs,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The velocity a trajectory reports is the time derivative of its angle.
    fn check_velocity_is_derivative(traj: &dyn JointTrajectory, n: usize, times: &[f64]) {
        let h = 1e-6;
        let (mut a0, mut a1, mut v, mut scratch) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for &t in times {
            traj.targets(t - h, &mut a0, &mut scratch);
            traj.targets(t + h, &mut a1, &mut scratch);
            traj.targets(t, &mut scratch, &mut v);
            for j in 0..n {
                let numeric = (a1[j] - a0[j]) / (2.0 * h);
                assert!((numeric - v[j]).abs() < 1e-5, "t={t} j={j}: {numeric} vs {}", v[j]);
            }
        }
    }

    #[test]
    fn sine_wave_values_ramp_and_derivative() {
        let w = SineWave { amplitude_rad: 0.5, frequency_hz: 0.8, phase_lag_rad: 0.7, offset_rad: 0.1, ramp_secs: 2.0 };
        let (mut a, mut v) = (vec![0.0; 5], vec![0.0; 5]);
        w.targets(0.0, &mut a, &mut v);
        assert!(a.iter().all(|x| *x == 0.0), "starts straight");
        w.targets(3.0, &mut a, &mut v);
        for (j, angle) in a.iter().enumerate() {
            let expected = 0.5 * (TAU * 0.8 * 3.0 - j as f64 * 0.7).sin() + 0.1;
            assert!((angle - expected).abs() < 1e-12);
        }
        check_velocity_is_derivative(&w, 5, &[0.3, 1.0, 1.99, 2.5, 7.1]);
    }

    #[test]
    fn wave_travels_from_head_to_tail() {
        // Joint j+1 reaches the value joint j had δ/ω seconds earlier.
        let w = SineWave { amplitude_rad: 0.5, frequency_hz: 1.0, phase_lag_rad: 0.4, offset_rad: 0.0, ramp_secs: 0.0 };
        let (mut a, mut b, mut v) = (vec![0.0; 2], vec![0.0; 2], vec![0.0; 2]);
        let dt = 0.4 / TAU;
        w.targets(1.0, &mut a, &mut v);
        w.targets(1.0 + dt, &mut b, &mut v);
        assert!((b[1] - a[0]).abs() < 1e-12);
    }

    #[test]
    fn serpenoid_forms_k_waves_and_two_plane_waves_split_by_axis() {
        let sp = serpenoid(0.5, 2.0, 10, 1.0, 0.0, 0.0);
        assert!((sp.phase_lag_rad - TAU * 2.0 / 10.0).abs() < 1e-12);
        assert!((sp.amplitude_rad - 2.0 * 0.5 * (std::f64::consts::PI * 0.2).sin()).abs() < 1e-12);
        let roll = TwoPlaneWave {
            yaw_amplitude_rad: 0.3,
            pitch_amplitude_rad: 0.3,
            frequency_hz: 1.0,
            phase_lag_rad: 0.0,
            pitch_phase_rad: std::f64::consts::FRAC_PI_2,
            ramp_secs: 0.0,
        };
        let (mut a, mut v) = (vec![0.0; 4], vec![0.0; 4]);
        roll.targets(0.0, &mut a, &mut v);
        assert_eq!(a[0], 0.0);
        assert!((a[1] - 0.3).abs() < 1e-12, "pitch joints lead by 90 degrees");
        check_velocity_is_derivative(&roll, 4, &[0.1, 0.77]);
        let side = TwoPlaneWave { phase_lag_rad: 0.6, pitch_amplitude_rad: 0.1, ramp_secs: 1.0, ..roll };
        check_velocity_is_derivative(&side, 6, &[0.2, 0.9, 3.3]);
    }

    #[test]
    fn form_closure_list_shifts_toward_tail() {
        let f = FormClosureShift { pattern_rad: vec![0.0, 0.1, 0.2, 0.3], shift_period_secs: 2.0 };
        let (mut a, mut v) = (vec![0.0; 6], vec![0.0; 6]);
        f.targets(0.0, &mut a, &mut v);
        assert_eq!(a, vec![0.0, 0.1, 0.2, 0.3, 0.0, 0.1]);
        f.targets(2.0, &mut a, &mut v);
        assert_eq!(a, vec![0.3, 0.0, 0.1, 0.2, 0.3, 0.0]);
        check_velocity_is_derivative(&f, 6, &[0.5, 1.0, 2.7, 5.3]);
    }
}

//! Sensor models: bias, random-walk bias, Gaussian noise, quantisation and sample-and-hold, per
//! sensor kind (`[sensors.<kind>]`), one seeded random stream per sensor.
//!
//! MuJoCo 3 ignores the `noise` attribute of sensors, so SimSerpent measures itself. For every
//! channel (one axis of one sensor), at a sample instant t:
//!
//! ```text
//! w(t)       = w(t_prev) + σ_rw·√(t − t_prev)·N(0,1)         (random-walk bias, w = 0 at start)
//! measured   = round_to_resolution(truth + bias + w(t) + σ·N(0,1))
//! ```
//!
//! and between sample instants (`rate_hz` > 0: every 1/rate_hz s, starting at the first step)
//! the last measured value is held. Each sensor (one joint encoder, one link's accelerometer, …)
//! has its own ChaCha8 stream seeded from `(general.seed, stream number)`, so adding a sensor
//! never changes another sensor's noise. With `noise_enabled = false` measured = truth exactly.
//!
//! An IMU's orientation (`[sensors.orientation]`) is measured as the true orientation turned by
//! a small rotation: its three channels (rotation vector in the link's axes, rad) are the error
//! terms above with a true value of 0, `q_measured = q_true ⊗ exp(e)`; at `rate_hz` the whole
//! measured orientation is held between samples.

use crate::config::{SensorModel, Sensors};
use crate::control::Observation;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Stream numbers: per joint 4 (angle, velocity, force, torque), per link 2 (accelerometer,
/// gyro) from `LINK_STREAM_OFFSET` on, per joint 1 (actuator torque) from
/// `ACTUATOR_STREAM_OFFSET` on, per link 1 (orientation) from `ORIENTATION_STREAM_OFFSET` on.
const JOINT_STREAMS: u64 = 4;
const LINK_STREAMS: u64 = 2;
const LINK_STREAM_OFFSET: u64 = 1_000_000;
const ACTUATOR_STREAM_OFFSET: u64 = 2_000_000;
const ORIENTATION_STREAM_OFFSET: u64 = 3_000_000;

fn stream(seed: u64, number: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(number);
    rng
}

/// The model of one sensor kind, with its state for every sensor of that kind.
#[derive(Clone)]
struct Kind {
    model: SensorModel,
    /// Values per sensor (1 for scalars, 3 for vectors).
    dims: usize,
    /// One stream per sensor.
    rngs: Vec<ChaCha8Rng>,
    /// Per channel: random-walk bias.
    walk: Vec<f64>,
    /// Per channel: the last sample (held between samples).
    held: Vec<f64>,
    /// Time of the last sample (None before the first).
    last_sample_secs: Option<f64>,
    next_sample_secs: f64,
}

impl Kind {
    fn new(model: SensorModel, dims: usize, seed: u64, streams: impl Iterator<Item = u64>) -> Self {
        let rngs: Vec<ChaCha8Rng> = streams.map(|n| stream(seed, n)).collect();
        let channels = rngs.len() * dims;
        Self {
            model,
            dims,
            rngs,
            walk: vec![0.0; channels],
            held: vec![0.0; channels],
            last_sample_secs: None,
            next_sample_secs: 0.0,
        }
    }

    /// Writes the measured values of `truth` (all sensors of this kind, flattened) into `out`.
    fn measure(&mut self, time_secs: f64, truth: &[f64], out: &mut [f64]) {
        let m = self.model;
        // The clock went back (a reset): start afresh.
        if self.last_sample_secs.is_some_and(|t| time_secs < t) {
            self.last_sample_secs = None;
        }
        let due = match self.last_sample_secs {
            None => true,
            Some(_) if m.rate_hz <= 0.0 => true,
            // A tolerance of a millionth of the period absorbs the rounding of t = k·dt.
            Some(_) => time_secs >= self.next_sample_secs - 1e-6 / m.rate_hz,
        };
        if due {
            let dt = self.last_sample_secs.map_or(0.0, |t| (time_secs - t).max(0.0));
            let walk_step = m.bias_random_walk_per_sqrt_s * dt.sqrt();
            for (s, rng) in self.rngs.iter_mut().enumerate() {
                for c in s * self.dims..(s + 1) * self.dims {
                    let (Some(&t), Some(walk), Some(held)) = (truth.get(c), self.walk.get_mut(c), self.held.get_mut(c))
                    else {
                        continue;
                    };
                    if walk_step > 0.0 {
                        let z: f64 = StandardNormal.sample(rng);
                        *walk += walk_step * z;
                    }
                    let mut v = t + m.bias + *walk;
                    if m.std > 0.0 {
                        let z: f64 = StandardNormal.sample(rng);
                        v += m.std * z;
                    }
                    if m.resolution > 0.0 {
                        v = (v / m.resolution).round() * m.resolution;
                    }
                    *held = v;
                }
            }
            if m.rate_hz > 0.0 {
                let period = 1.0 / m.rate_hz;
                self.next_sample_secs = match self.last_sample_secs {
                    None => time_secs + period,
                    // Keep the sampling grid; if a sample was missed, restart it from now.
                    Some(_) if self.next_sample_secs + period > time_secs => self.next_sample_secs + period,
                    Some(_) => time_secs + period,
                };
            }
            self.last_sample_secs = Some(time_secs);
        }
        for (o, h) in out.iter_mut().zip(&self.held) {
            *o = *h;
        }
    }
}

/// Measures a true observation with the configured sensor models.
#[derive(Clone)]
pub struct SensorNoise {
    enabled: bool,
    joint_angle: Kind,
    joint_velocity: Kind,
    actuator_torque: Kind,
    joint_force: Kind,
    joint_torque: Kind,
    accelerometer: Kind,
    gyro: Kind,
    orientation: Kind,
    /// Per link: 0 (the orientation error's "true value") and the error's rotation vector.
    orientation_zero: Vec<f64>,
    orientation_error: Vec<f64>,
    /// Per link: the measured orientation held between samples.
    orientation_held: Vec<[f64; 4]>,
}

impl SensorNoise {
    /// Sensor models and random streams for `n_links` links and `n_joints` joints.
    pub fn new(config: &Sensors, seed: u64, n_links: usize, n_joints: usize) -> Self {
        let (nl, nj) = (n_links as u64, n_joints as u64);
        let joint = |k: u64| (0..nj).map(move |j| j * JOINT_STREAMS + k);
        let link = |k: u64| (0..nl).map(move |i| LINK_STREAM_OFFSET + nj * JOINT_STREAMS + i * LINK_STREAMS + k);
        Self {
            enabled: config.noise_enabled,
            joint_angle: Kind::new(config.joint_angle, 1, seed, joint(0)),
            joint_velocity: Kind::new(config.joint_velocity, 1, seed, joint(1)),
            joint_force: Kind::new(config.joint_force, 3, seed, joint(2)),
            joint_torque: Kind::new(config.joint_torque, 3, seed, joint(3)),
            actuator_torque: Kind::new(config.actuator_torque, 1, seed, (0..nj).map(|j| ACTUATOR_STREAM_OFFSET + j)),
            accelerometer: Kind::new(config.accelerometer, 3, seed, link(0)),
            gyro: Kind::new(config.gyro, 3, seed, link(1)),
            orientation: Kind::new(config.orientation, 3, seed, (0..nl).map(|i| ORIENTATION_STREAM_OFFSET + i)),
            orientation_zero: vec![0.0; n_links * 3],
            orientation_error: vec![0.0; n_links * 3],
            orientation_held: vec![[1.0, 0.0, 0.0, 0.0]; n_links],
        }
    }

    /// `measured` = the sensor models applied to `truth` (a plain copy when noise is off). Does
    /// not allocate.
    pub fn measure(&mut self, truth: &Observation, measured: &mut Observation) {
        measured.copy_from(truth);
        if !self.enabled {
            return;
        }
        let t = truth.time_secs;
        self.joint_angle.measure(t, &truth.joint_angle_rad, &mut measured.joint_angle_rad);
        self.joint_velocity.measure(t, &truth.joint_velocity_rad_per_s, &mut measured.joint_velocity_rad_per_s);
        self.actuator_torque.measure(t, &truth.actuator_torque_nm, &mut measured.actuator_torque_nm);
        self.joint_force.measure(t, truth.joint_force_n.as_flattened(), measured.joint_force_n.as_flattened_mut());
        self.joint_torque.measure(t, truth.joint_torque_nm.as_flattened(), measured.joint_torque_nm.as_flattened_mut());
        self.accelerometer.measure(
            t,
            truth.imu_accel_m_per_s2.as_flattened(),
            measured.imu_accel_m_per_s2.as_flattened_mut(),
        );
        self.gyro.measure(t, truth.imu_gyro_rad_per_s.as_flattened(), measured.imu_gyro_rad_per_s.as_flattened_mut());
        self.orientation.measure(t, &self.orientation_zero, &mut self.orientation_error);
        // A new sample (the kind sampled at this instant): turn the true orientation by the error.
        if self.orientation.last_sample_secs == Some(t) {
            for ((held, q), e) in
                self.orientation_held.iter_mut().zip(&truth.imu_quat_wxyz).zip(self.orientation_error.chunks_exact(3))
            {
                *held = rotate_by_vector(*q, [e[0], e[1], e[2]]);
            }
        }
        for (m, held) in measured.imu_quat_wxyz.iter_mut().zip(&self.orientation_held) {
            *m = *held;
        }
    }
}

/// `q ⊗ exp(e)`: the orientation `q` (w, x, y, z) turned by the rotation vector `e` (rad, in
/// the body's own axes), normalised.
fn rotate_by_vector(q: [f64; 4], e: [f64; 3]) -> [f64; 4] {
    let angle = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    let (s, c) = if angle > 0.0 { ((angle / 2.0).sin() / angle, (angle / 2.0).cos()) } else { (0.5, 1.0) };
    let r = [c, s * e[0], s * e[1], s * e[2]];
    let [w1, x1, y1, z1] = q;
    let [w2, x2, y2, z2] = r;
    let p = [
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ];
    let norm = p.iter().map(|v| v * v).sum::<f64>().sqrt();
    if norm > 0.0 { p.map(|v| v / norm) } else { q }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    const DT: f64 = 0.001;

    fn quiet() -> SensorModel {
        SensorModel { std: 0.0, bias: 0.0, bias_random_walk_per_sqrt_s: 0.0, resolution: 0.0, rate_hz: 0.0 }
    }

    /// Measures a constant truth `value` on every channel for `n` steps of `DT` with the given
    /// sensor models; returns every kind's first channel per step:
    /// [joint angle, joint velocity, actuator torque, force x, torque x, accelerometer x, gyro x].
    fn sample(sensors: &Sensors, seed: u64, n: usize, value: f64) -> Vec<[f64; 7]> {
        let mut noise = SensorNoise::new(sensors, seed, 2, 1);
        let mut truth = Observation::new(2, 1);
        truth.joint_angle_rad[0] = value;
        truth.joint_velocity_rad_per_s[0] = value;
        truth.actuator_torque_nm[0] = value;
        truth.joint_force_n[0] = [value; 3];
        truth.joint_torque_nm[0] = [value; 3];
        truth.imu_accel_m_per_s2 = vec![[value; 3]; 2];
        truth.imu_gyro_rad_per_s = vec![[value; 3]; 2];
        let mut m = Observation::new(2, 1);
        (0..n)
            .map(|k| {
                truth.time_secs = k as f64 * DT;
                noise.measure(&truth, &mut m);
                [
                    m.joint_angle_rad[0],
                    m.joint_velocity_rad_per_s[0],
                    m.actuator_torque_nm[0],
                    m.joint_force_n[0][0],
                    m.joint_torque_nm[0][0],
                    m.imu_accel_m_per_s2[0][0],
                    m.imu_gyro_rad_per_s[0][0],
                ]
            })
            .collect()
    }

    fn all_kinds(model: SensorModel) -> Sensors {
        let mut s = Config::default().sensors;
        s.noise_enabled = true;
        for m in [
            &mut s.joint_angle,
            &mut s.joint_velocity,
            &mut s.actuator_torque,
            &mut s.joint_force,
            &mut s.joint_torque,
            &mut s.accelerometer,
            &mut s.gyro,
        ] {
            *m = model;
        }
        s
    }

    fn mean_std(xs: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
        let n = xs.clone().count() as f64;
        let mean = xs.clone().sum::<f64>() / n;
        let var = xs.map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    }

    /// The rotation vector (rad, body axes) that turns `a` into `b`: 2·log(a⁻¹ ⊗ b).
    fn rotation_between(a: [f64; 4], b: [f64; 4]) -> [f64; 3] {
        let [w1, x1, y1, z1] = [a[0], -a[1], -a[2], -a[3]];
        let [w2, x2, y2, z2] = b;
        let w = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2;
        let v = [
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ];
        let sin_half = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let angle = 2.0 * sin_half.atan2(w);
        if sin_half > 0.0 { v.map(|c| c * angle / sin_half) } else { [0.0; 3] }
    }

    /// The orientation's error is a rotation with the configured bias and std per axis; its
    /// covariance (what ROS 2's Imu publishes) is std² on the diagonal; noise off is exact; at
    /// rate_hz the measured orientation is held between samples.
    #[test]
    fn orientation_is_the_truth_turned_by_the_configured_error() {
        let (n, std, bias) = (20_000, 0.01, 0.002);
        let mut sensors = Config::default().sensors;
        sensors.noise_enabled = true;
        sensors.orientation = SensorModel { std, bias, ..quiet() };
        let mut noise = SensorNoise::new(&sensors, 3, 2, 1);
        let mut truth = Observation::new(2, 1);
        let mut m = Observation::new(2, 1);
        let mut errors = Vec::with_capacity(n);
        for k in 0..n {
            let yaw = 0.001 * k as f64;
            truth.time_secs = k as f64 * DT;
            truth.imu_quat_wxyz[1] = [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()];
            noise.measure(&truth, &mut m);
            let q = m.imu_quat_wxyz[1];
            assert!(((q.iter().map(|v| v * v).sum::<f64>()) - 1.0).abs() < 1e-12, "unit quaternion {q:?}");
            errors.push(rotation_between(truth.imu_quat_wxyz[1], q));
        }
        for axis in 0..3 {
            let (mean, s) = mean_std(errors.iter().map(|e| e[axis]));
            assert!((mean - bias).abs() < 4.0 * std / (n as f64).sqrt(), "axis {axis}: mean {mean}");
            assert!((s - std).abs() < 4.0 * std / (2.0 * n as f64).sqrt(), "axis {axis}: std {s}");
        }
        // Noise off: exactly the truth.
        sensors.noise_enabled = false;
        let mut exact = SensorNoise::new(&sensors, 3, 2, 1);
        exact.measure(&truth, &mut m);
        assert_eq!(m.imu_quat_wxyz, truth.imu_quat_wxyz);
        // 100 Hz on 1-ms steps: ten steps share one measured orientation while the truth turns.
        sensors.noise_enabled = true;
        sensors.orientation.rate_hz = 100.0;
        let mut held = SensorNoise::new(&sensors, 3, 2, 1);
        let mut seen = Vec::new();
        for k in 0..20 {
            truth.time_secs = k as f64 * DT;
            truth.imu_quat_wxyz[0] = [(0.005 * k as f64).cos(), 0.0, 0.0, (0.005 * k as f64).sin()];
            held.measure(&truth, &mut m);
            seen.push(m.imu_quat_wxyz[0]);
        }
        assert!(seen[..10].iter().all(|q| *q == seen[0]) && seen[10..].iter().all(|q| *q == seen[10]));
        assert_ne!(seen[0], seen[10]);
    }

    #[test]
    fn every_kind_has_the_configured_mean_and_std_and_is_seeded() {
        let (n, std, bias) = (20_000, 0.01, 0.003);
        let sensors = all_kinds(SensorModel { std, bias, ..quiet() });
        let xs = sample(&sensors, 7, n, 0.25);
        for k in 0..7 {
            let (mean, s) = mean_std(xs.iter().map(|x| x[k] - 0.25));
            // Standard error of the mean: σ/√n = 7e-5; of the std: σ/√(2n) = 5e-5.
            assert!((mean - bias).abs() < 4.0 * std / (n as f64).sqrt(), "kind {k}: mean {mean}");
            assert!((s - std).abs() < 4.0 * std / (2.0 * n as f64).sqrt(), "kind {k}: std {s}");
        }
        // Kinds draw from different streams.
        assert_ne!(xs[0][0], xs[0][1]);
        assert_eq!(xs, sample(&sensors, 7, n, 0.25), "same seed, same noise");
        assert_ne!(xs, sample(&sensors, 8, n, 0.25), "another seed, other noise");
    }

    #[test]
    fn quantisation_rounds_to_the_resolution() {
        let sensors = all_kinds(SensorModel { resolution: 0.1, ..quiet() });
        for x in sample(&sensors, 1, 3, 0.26).into_iter().flatten() {
            assert!((x - 0.3).abs() < 1e-12, "{x}");
        }
        // With noise, every reading is a multiple of the resolution.
        let sensors = all_kinds(SensorModel { std: 0.5, resolution: 0.1, ..quiet() });
        for x in sample(&sensors, 1, 1000, 0.26).into_iter().flatten() {
            assert!(((x / 0.1) - (x / 0.1).round()).abs() < 1e-9, "{x}");
        }
    }

    #[test]
    fn sample_and_hold_updates_at_the_rate() {
        // 100 Hz at 1 ms steps: a new value every 10 steps, held in between.
        let sensors = all_kinds(SensorModel { std: 1.0, rate_hz: 100.0, ..quiet() });
        let xs = sample(&sensors, 3, 100, 0.0);
        let mut changes = 0;
        for k in 1..xs.len() {
            if xs[k] != xs[k - 1] {
                assert_eq!(k % 10, 0, "a new sample at step {k}");
                changes += 1;
            }
        }
        assert_eq!(changes, 9);
    }

    #[test]
    fn random_walk_bias_grows_like_sqrt_time() {
        // After T seconds the walk has std σ_rw·√T. Over 2000 independent channels (sensors of
        // many seeds), the sample std after T = 0.1 s is within 4 standard errors
        // (σ/√(2n) ≈ 1.6 %).
        let sigma = 0.2;
        let expected = sigma * 0.1f64.sqrt();
        let sensors = all_kinds(SensorModel { bias_random_walk_per_sqrt_s: sigma, ..quiet() });
        let finals: Vec<f64> = (0..2000u64).map(|seed| sample(&sensors, seed, 101, 0.0)[100][3]).collect();
        let (mean, s) = mean_std(finals.iter().copied());
        let se = expected / (2.0 * finals.len() as f64).sqrt();
        assert!((s - expected).abs() < 4.0 * se, "walk std after 0.1 s: {s}, expected {expected}");
        assert!(mean.abs() < 4.0 * expected / (finals.len() as f64).sqrt(), "walk mean {mean}");
    }

    #[test]
    fn noise_off_gives_exact_values() {
        let mut sensors = all_kinds(SensorModel { std: 1.0, bias: 1.0, resolution: 0.5, rate_hz: 10.0, ..quiet() });
        sensors.noise_enabled = false;
        for x in sample(&sensors, 1, 10, 0.123).into_iter().flatten() {
            assert_eq!(x, 0.123);
        }
    }
}

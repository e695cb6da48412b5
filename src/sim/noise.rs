//! Sensor noise: zero-mean Gaussian, one seeded random stream per sensor channel group.
//!
//! MuJoCo 3 ignores the `noise` attribute of sensors, so SimSerpent adds noise itself. Each
//! sensor (one joint encoder, one link's accelerometer, …) has its own ChaCha8 stream seeded from
//! `(general.seed, stream number)`, so adding a sensor never changes another sensor's noise.

use crate::config::Sensors;
use crate::control::Observation;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Streams per joint: angle, velocity, force, torque. Per link: accelerometer, gyro.
const JOINT_STREAMS: usize = 4;
const LINK_STREAMS: usize = 2;

/// Adds the configured noise to a true observation.
pub struct SensorNoise {
    enabled: bool,
    std: Sensors,
    joint_rngs: Vec<ChaCha8Rng>,
    link_rngs: Vec<ChaCha8Rng>,
}

fn stream(seed: u64, number: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(number);
    rng
}

fn gauss(rng: &mut ChaCha8Rng, std: f64) -> f64 {
    let z: f64 = StandardNormal.sample(rng);
    z * std
}

fn add3(rng: &mut ChaCha8Rng, std: f64, value: &mut [f64; 3]) {
    for v in value.iter_mut() {
        *v += gauss(rng, std);
    }
}

impl SensorNoise {
    /// Noise streams for `n_links` links and `n_joints` joints.
    pub fn new(config: &Sensors, seed: u64, n_links: usize, n_joints: usize) -> Self {
        let joint_rngs = (0..n_joints * JOINT_STREAMS).map(|k| stream(seed, k as u64)).collect();
        let offset = (n_joints * JOINT_STREAMS) as u64 + 1_000_000;
        let link_rngs = (0..n_links * LINK_STREAMS).map(|k| stream(seed, offset + k as u64)).collect();
        Self { enabled: config.noise_enabled, std: config.clone(), joint_rngs, link_rngs }
    }

    /// `measured` = `truth` + noise (or a plain copy when noise is off). Does not allocate.
    pub fn measure(&mut self, truth: &Observation, measured: &mut Observation) {
        measured.copy_from(truth);
        if !self.enabled {
            return;
        }
        let s = &self.std;
        for j in 0..truth.n_joints() {
            let rngs = &mut self.joint_rngs[j * JOINT_STREAMS..(j + 1) * JOINT_STREAMS];
            measured.joint_angle_rad[j] += gauss(&mut rngs[0], s.joint_angle_std_rad);
            measured.joint_velocity_rad_per_s[j] += gauss(&mut rngs[1], s.joint_velocity_std_rad_per_s);
            add3(&mut rngs[2], s.joint_force_std_n, &mut measured.joint_force_n[j]);
            add3(&mut rngs[3], s.joint_torque_std_nm, &mut measured.joint_torque_nm[j]);
        }
        for i in 0..truth.imu_accel_m_per_s2.len() {
            let rngs = &mut self.link_rngs[i * LINK_STREAMS..(i + 1) * LINK_STREAMS];
            add3(&mut rngs[0], s.accelerometer_std_m_per_s2, &mut measured.imu_accel_m_per_s2[i]);
            add3(&mut rngs[1], s.gyro_std_rad_per_s, &mut measured.imu_gyro_rad_per_s[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    fn sample(seed: u64, n: usize) -> Vec<f64> {
        let mut cfg = Config::default().sensors;
        cfg.noise_enabled = true;
        cfg.joint_angle_std_rad = 0.01;
        let mut noise = SensorNoise::new(&cfg, seed, 2, 1);
        let truth = Observation::new(2, 1);
        let mut measured = Observation::new(2, 1);
        (0..n)
            .map(|_| {
                noise.measure(&truth, &mut measured);
                measured.joint_angle_rad[0]
            })
            .collect()
    }

    #[test]
    fn noise_has_configured_mean_and_std_and_is_seeded() {
        let n = 20_000;
        let xs = sample(7, n);
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        // Standard error of the mean: 0.01/sqrt(n) = 7e-5; of the std: 0.01/sqrt(2n) = 5e-5.
        assert!(mean.abs() < 4.0 * 0.01 / (n as f64).sqrt(), "mean {mean}");
        assert!((var.sqrt() - 0.01).abs() < 4.0 * 0.01 / (2.0 * n as f64).sqrt(), "std {}", var.sqrt());
        assert_eq!(xs, sample(7, n), "same seed, same noise");
        assert_ne!(xs, sample(8, n), "another seed, other noise");
    }

    #[test]
    fn noise_off_gives_exact_values() {
        let cfg = Config::default().sensors;
        assert!(!cfg.noise_enabled);
        let mut noise = SensorNoise::new(&cfg, 1, 2, 1);
        let mut truth = Observation::new(2, 1);
        truth.joint_angle_rad[0] = 0.25;
        let mut measured = Observation::new(2, 1);
        noise.measure(&truth, &mut measured);
        assert_eq!(measured.joint_angle_rad[0], 0.25);
    }
}

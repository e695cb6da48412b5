//! Cost of the step loop's contact estimator (`estimation::MotionEstimator::update`) per step,
//! for 10 and 30 links, without MuJoCo: the estimator gets a moving observation (a travelling
//! wave in the encoders, gyros and force sensors) and runs as it does in `Simulation::sense`.
//!
//! ```sh
//! cargo run --release --example estimator_cost            # wall time per update
//! valgrind --tool=callgrind target/release/examples/estimator_cost 10000   # instructions
//! ```
//!
//! The optional argument is the number of updates per snake size (default 200 000); a second
//! argument `identify` runs it with `estimation.friction = "identify"`.

use simserpent::config::Config;
use simserpent::control::Observation;
use simserpent::estimation::{ContactEstimates, MotionEstimator};
use std::time::Instant;

fn main() {
    let updates: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(200_000);
    let identify = std::env::args().nth(2).as_deref() == Some("identify");
    for n_links in [10, 30] {
        let mut config = Config::default();
        config.snake.n_links = n_links;
        config.estimation.enabled = true;
        if identify {
            config.estimation.friction = simserpent::config::FloorFrictionSource::Identify;
        }
        let masses = vec![config.snake.link_mass_kg; n_links];
        let mut estimator = MotionEstimator::from_config(&config, &masses);
        let mut obs = Observation::new(n_links, n_links - 1);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        let mut out = ContactEstimates::new(n_links);
        let dt = 0.001;
        let mut checksum = 0.0;
        let start = Instant::now();
        for k in 0..updates {
            let t = k as f64 * dt;
            obs.time_secs = t;
            obs.sensor_time_secs = t;
            obs.head_velocity_m_per_s = [0.05, 0.02 * (3.0 * t).sin(), 0.0];
            for (j, q) in obs.joint_angle_rad.iter_mut().enumerate() {
                *q = 0.5 * (3.0 * t - 0.7 * j as f64).sin();
            }
            for (i, (a, g)) in obs.imu_accel_m_per_s2.iter_mut().zip(obs.imu_gyro_rad_per_s.iter_mut()).enumerate() {
                let phase = 3.0 * t - 0.7 * i as f64;
                *a = [0.3 * phase.cos(), 0.5 * phase.sin(), 9.81];
                *g = [0.0, 0.0, 1.5 * phase.cos()];
            }
            for (j, f) in obs.joint_force_n.iter_mut().enumerate() {
                let phase = 3.0 * t - 0.7 * j as f64;
                *f = [0.4 * phase.sin(), 1.2 * phase.cos(), 0.5];
            }
            estimator.update(&obs, None, &mut out);
            checksum += out.obstacle_force_n[n_links / 2][1];
        }
        let secs = start.elapsed().as_secs_f64();
        println!(
            "{n_links} links: {:.2} µs per update ({updates} updates, checksum {checksum:.3})",
            1e6 * secs / updates as f64
        );
    }
}

//! Writing your own force-feedback controller with the contact estimates.
//!
//! Run with: `cargo run --release --example force_feedback_controller`
//!
//! With `[estimation] enabled = true` the step loop estimates, from the measured joint
//! force/torque sensors and IMUs, which links touch an obstacle and how hard
//! (`Observation::contacts`: per link `contact`, `obstacle_force_n` in the world frame,
//! `contact_point_along_m`). This controller runs lateral undulation and, at every link that
//! touches a peg, bends the two joints around that link away from the peg in proportion to the
//! push (a compliant snake that slips past what it touches). The built-in contact laws from the
//! literature (`control.controller = "follow_the_leader_reflex"`, `"directional_admittance"`,
//! `"jam_resolution"`) are full versions: they bend toward the pegs that propel and yield to
//! those that resist; the `oal_bench` example shows how to score a law of one's own against them
//! (`cargo run --release --example oal_bench -- --mine`).

use simserpent::config::{self, ConfigSource};
use simserpent::control::{Command, Controller, Observation};
use simserpent::run::{self, RunOptions};

struct Compliant {
    amplitude_rad: f64,
    omega_rad_per_s: f64,
    phase_lag_rad: f64,
    /// Joint offset per newton of lateral obstacle force (rad/N).
    gain_rad_per_n: f64,
}

/// Yaw of a unit quaternion (w, x, y, z).
fn yaw(q: [f64; 4]) -> f64 {
    (2.0 * (q[1] * q[2] + q[0] * q[3])).atan2(1.0 - 2.0 * (q[2] * q[2] + q[3] * q[3]))
}

impl Controller for Compliant {
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        let t = obs.time_secs;
        for (j, target) in cmd.position_rad.iter_mut().enumerate() {
            *target = self.amplitude_rad * (self.omega_rad_per_s * t - j as f64 * self.phase_lag_rad).sin();
        }
        let c = &obs.contacts;
        if !c.active {
            return; // estimation is off
        }
        // Link headings: the head's yaw, then each joint angle (child heading − parent heading).
        let mut heading = yaw(obs.head_quat);
        for i in 0..c.n_links() {
            if i > 0 {
                heading += obs.joint_angle_rad[i - 1];
            }
            if !c.contact[i] {
                continue;
            }
            // The push across the link (positive: toward the link's left).
            let f = c.obstacle_force_n[i];
            let lateral_n = -heading.sin() * f[0] + heading.cos() * f[1];
            // Joint i−1 is in front of link i, joint i behind it. Turning the front joint one
            // way and the rear joint the other moves the link's rear end sideways: toward the
            // push's direction here (away from the peg).
            let bend = self.gain_rad_per_n * lateral_n;
            if i > 0 {
                cmd.position_rad[i - 1] -= bend;
            }
            if i < cmd.position_rad.len() {
                cmd.position_rad[i] += bend;
            }
        }
    }
}

fn main() -> anyhow::Result<()> {
    // The default config with a random peg field ahead and around the snake, and estimation on.
    let overrides = [
        "general.run_name=force_feedback_controller".to_string(),
        "general.duration_secs=5".to_string(),
        "control.method=position".to_string(),
        "terrain.kind=none".to_string(),
        "terrain.pegboard.layout=random".to_string(),
        "terrain.pegboard.count=20".to_string(),
        "terrain.pegboard.region_min_m=[-2.2, -0.6]".to_string(),
        "terrain.pegboard.region_max_m=[2.0, 0.6]".to_string(),
        "terrain.pegboard.spacing_m=0.35".to_string(),
        "estimation.enabled=true".to_string(),
    ];
    let config = config::load_config_str(config::DEFAULT_CONFIG_TOML, ConfigSource::Toml, &overrides)?;
    let w = &config.gait.sine_wave;
    let controller = Compliant {
        amplitude_rad: w.amplitude_deg.to_radians(),
        omega_rad_per_s: std::f64::consts::TAU * w.frequency_hz,
        phase_lag_rad: w.phase_lag_deg.to_radians(),
        gain_rad_per_n: 0.02,
    };
    let options = RunOptions { config_source: "examples/force_feedback_controller.rs".into(), ..RunOptions::default() };
    let summary = run::run_with_controller(&config, &options, Box::new(controller))?;
    println!(
        "recorded in {} (estimates next to the truth in estimates.csv); moved {:.3} m",
        summary.run_folder.display(),
        summary.distance_m
    );
    Ok(())
}

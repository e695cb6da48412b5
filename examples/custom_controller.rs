//! Writing your own controller.
//!
//! Run with: `cargo run --release --example custom_controller`
//!
//! A controller is any type that implements `simserpent::control::Controller`: every physics
//! step it gets the measured `Observation` (time, joint angles and velocities, head pose, IMU and
//! joint force/torque readings) and fills a `Command` (one value per joint for the actuator kind
//! that `control.method` in the config selects). Everything else — model, terrain, recording,
//! run folder, summary — comes from the config, exactly as with `simserpent run`.

use simserpent::config::{self, ConfigSource, ControlMethod};
use simserpent::control::{Command, Controller, Observation};
use simserpent::run::{self, RunOptions};

/// Lateral undulation whose amplitude shrinks while the head turns fast: a small example of
/// feedback from the gyro.
struct CalmUndulation {
    amplitude_rad: f64,
    omega_rad_per_s: f64,
    phase_lag_rad: f64,
}

impl Controller for CalmUndulation {
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        let head_yaw_rate = obs.imu_gyro_rad_per_s[0][2].abs();
        let amplitude = self.amplitude_rad / (1.0 + head_yaw_rate);
        for (j, target) in cmd.position_rad.iter_mut().enumerate() {
            *target = amplitude * (self.omega_rad_per_s * obs.time_secs - j as f64 * self.phase_lag_rad).sin();
        }
    }
}

fn main() -> anyhow::Result<()> {
    // Start from the embedded default and override a few keys, as `--set` would.
    let overrides = [
        "general.run_name=custom_controller".to_string(),
        "general.duration_secs=5".to_string(),
        "control.method=position".to_string(),
    ];
    let config = config::load_config_str(config::DEFAULT_CONFIG_TOML, ConfigSource::Toml, &overrides)?;
    assert_eq!(config.control.method, ControlMethod::Position);
    let controller = CalmUndulation { amplitude_rad: 0.5, omega_rad_per_s: 3.0, phase_lag_rad: 0.7 };
    let options = RunOptions { config_source: "examples/custom_controller.rs".into(), ..RunOptions::default() };
    let summary = run::run_with_controller(&config, &options, Box::new(controller))?;
    println!("recorded in {}; moved {:.3} m", summary.run_folder.display(), summary.distance_m);
    Ok(())
}

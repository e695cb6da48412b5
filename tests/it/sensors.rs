//! Sensor models as they show in a run's `sensors.csv` (true and measured columns side by side).

use crate::common::{read_csv_numbers, run_folder};
use simserpent::config::{Config, GaitKind, SensorModel, TerrainKind};
use std::path::Path;

fn white(std: f64, bias: f64) -> SensorModel {
    SensorModel { std, bias, bias_random_walk_per_sqrt_s: 0.0, resolution: 0.0, rate_hz: 0.0 }
}

fn config(dir: &Path, seed: u64) -> Config {
    let mut c = Config::default();
    c.general.output_dir = dir.display().to_string();
    c.general.seed = seed;
    c.general.duration_secs = 2.0;
    c.general.timestep_secs = 0.001;
    c.snake.n_links = 3;
    c.terrain.kind = TerrainKind::None;
    c.gait.kind = GaitKind::SineWave;
    c.recording.every_n_steps = 1;
    let s = &mut c.sensors;
    s.noise_enabled = true;
    s.accelerometer = white(0.05, 0.02);
    s.joint_velocity = white(0.01, -0.003);
    s.actuator_torque = white(0.02, 0.005);
    s.joint_force = white(0.1, 0.03);
    s.joint_torque = white(0.01, -0.002);
    // Quantised encoder without noise; gyro sampled at 100 Hz (every 10th step), held.
    s.joint_angle = SensorModel { resolution: 0.01, ..white(0.0, 0.0) };
    s.gyro = SensorModel { rate_hz: 100.0, ..white(0.005, 0.001) };
    c
}

/// (measured column, true column) index pairs whose names contain `what`.
fn pairs(header: &[String], what: &str) -> Vec<(usize, usize)> {
    header
        .iter()
        .enumerate()
        .filter(|(_, h)| h.contains(what) && h.contains("_measured"))
        .map(|(m, h)| (m, header.iter().position(|x| *x == h.replace("_measured", "_true")).unwrap()))
        .collect()
}

fn run_sensors(seed: u64) -> (Vec<String>, Vec<Vec<f64>>) {
    let dir = tempfile::tempdir().unwrap();
    let folder = run_folder(&config(dir.path(), seed));
    read_csv_numbers(&folder.join("sensors.csv"))
}

#[test]
fn recorded_noise_has_the_configured_bias_and_std_quantisation_and_rate() {
    let (header, rows) = run_sensors(5);
    let c = config(Path::new("."), 5).sensors;
    let kinds = [
        ("accelerometer", c.accelerometer, 1),
        ("encoder_velocity", c.joint_velocity, 1),
        ("actuator_torque", c.actuator_torque, 1),
        ("force_sensor", c.joint_force, 1),
        ("torque_sensor", c.joint_torque, 1),
        // A new gyro sample every 10 steps: 10 times fewer independent values.
        ("gyro", c.gyro, 10),
    ];
    for (what, model, hold) in kinds {
        let columns = pairs(&header, what);
        assert!(!columns.is_empty(), "{what}");
        for (m, t) in columns {
            let errors: Vec<f64> = rows.iter().step_by(hold).map(|r| r[m] - r[t]).collect();
            let n = errors.len() as f64;
            let mean = errors.iter().sum::<f64>() / n;
            let std = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            // 4 standard errors of the mean (σ/√n) and of the std (σ/√(2(n−1))).
            assert!((mean - model.bias).abs() < 4.0 * model.std / n.sqrt(), "{}: mean {mean}", header[m]);
            assert!((std - model.std).abs() < 4.0 * model.std / (2.0 * (n - 1.0)).sqrt(), "{}: std {std}", header[m]);
        }
    }
    // Sample and hold: the gyro's measured value changes only on every 10th row.
    for (m, _) in pairs(&header, "gyro") {
        for k in 1..rows.len() {
            if rows[k][m] != rows[k - 1][m] {
                assert_eq!(k % 10, 0, "{} changed at row {k}", header[m]);
            }
        }
    }
    // Quantisation: the encoder reads the true angle rounded to 0.01 rad.
    let encoder = pairs(&header, "_encoder_measured_rad");
    assert_eq!(encoder.len(), 2);
    for (m, t) in encoder {
        for r in &rows {
            assert!((r[m] - (r[t] / 0.01).round() * 0.01).abs() < 1e-12, "{}: {} vs {}", header[m], r[m], r[t]);
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_noise_and_another_seed_other_noise() {
    let (header, a) = run_sensors(5);
    let (_, b) = run_sensors(5);
    let (_, c) = run_sensors(6);
    let cols = pairs(&header, "force_sensor");
    let noise = |rows: &Vec<Vec<f64>>| -> Vec<f64> {
        rows.iter().flat_map(|r| cols.iter().map(|&(m, t)| r[m] - r[t])).collect()
    };
    assert_eq!(noise(&a), noise(&b));
    assert_ne!(noise(&a), noise(&c));
}

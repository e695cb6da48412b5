//! `simserpent bench`: steps per second of the bare engine against the full pipeline.
//!
//! For each snake size the same generated model (default config: lateral undulation through the
//! position servos, cylinder path, RK4, 1 ms) is stepped three ways:
//! - **bare, still**: `mj_step` only, controls left at zero (no controller, no read-out, no
//!   recording) — the "bare engine";
//! - **bare, gait**: `mj_step` with the sine-wave set-points written straight into `ctrl` — the
//!   same motion and contacts as the full run, with nothing else;
//! - **full (CSV)**: `run::run` — controller, sensor noise model, read-out, CSV recording of
//!   every table at the configured interval, run folder and manifest;
//! - **full (Parquet)**: the same, recording Parquet tables instead (feature `parquet`);
//! - **full (MCAP)**: the same, writing only the ROS 2 bag (`run.mcap`) instead.
//!
//! "Bare, gait" is the fair baseline: the same motion and contacts, so the same work for MuJoCo.
//!
//! Wall time only counts the stepping (model compilation is excluded in all three).

use crate::config::{Config, ControlMethod, TableFormat};
use crate::control::{JointTrajectory, trajectory_from_config};
use crate::run::{self, RunError, RunOptions};
use crate::sim::{SimError, World};
use std::time::Instant;

/// One measured row.
#[derive(Debug, Clone)]
pub struct BenchRow {
    /// Links.
    pub n_links: usize,
    /// What was measured.
    pub mode: &'static str,
    /// Steps taken.
    pub steps: u64,
    /// Steps per wall second.
    pub steps_per_sec: f64,
}

fn bare(config: &Config, steps: u64, with_gait: bool) -> Result<f64, SimError> {
    let mut world = World::from_config(config)?;
    let trajectory: Box<dyn JointTrajectory> = trajectory_from_config(config);
    let n = world.n_joints();
    let kind = ControlMethod::ALL.iter().position(|m| *m == config.control.method).unwrap_or(0);
    let actuator_ids: Vec<usize> = world.index.joints.iter().filter_map(|j| j.actuators[kind]).collect();
    let (mut angle, mut velocity) = (vec![0.0; n], vec![0.0; n]);
    let dt = config.general.timestep_secs;
    let start = Instant::now();
    for k in 0..steps {
        if with_gait {
            trajectory.targets(k as f64 * dt, &mut angle, &mut velocity);
            let ctrl = world.ctrl_mut();
            for (a, target) in actuator_ids.iter().zip(&angle) {
                ctrl[*a] = *target;
            }
        }
        world.step();
    }
    Ok(steps as f64 / start.elapsed().as_secs_f64())
}

/// The modes measured per snake size, in output order.
pub fn modes() -> Vec<&'static str> {
    let mut m = vec![BARE_STILL, BARE_GAIT, FULL_CSV];
    if cfg!(feature = "parquet") {
        m.push(FULL_PARQUET);
    }
    m.push(FULL_MCAP);
    m
}

/// `mj_step` only, controls at zero.
pub const BARE_STILL: &str = "bare, still";
/// `mj_step` with the gait written into `ctrl`: the baseline (a).
pub const BARE_GAIT: &str = "bare, gait";
/// `run::run` recording CSV tables (b).
pub const FULL_CSV: &str = "full pipeline (CSV)";
/// `run::run` recording Parquet tables (c).
pub const FULL_PARQUET: &str = "full pipeline (Parquet)";
/// `run::run` writing only the ROS 2 bag (`run.mcap`, README "ROS 2").
pub const FULL_MCAP: &str = "full pipeline (MCAP)";

fn measure(config: &Config, mode: &str, steps: u64) -> Result<f64, RunError> {
    match mode {
        BARE_STILL => Ok(bare(config, steps, false)?),
        BARE_GAIT => Ok(bare(config, steps, true)?),
        _ => {
            let mut config = config.clone();
            config.recording.format = match mode {
                FULL_PARQUET => TableFormat::Parquet,
                FULL_MCAP => TableFormat::Mcap,
                _ => TableFormat::Csv,
            };
            let options = RunOptions { config_source: "bench".into(), ..RunOptions::default() };
            let summary = run::run(&config, &options)?;
            // Only the last folder of each mode is kept: benches should not fill the disk.
            let _ = std::fs::remove_dir_all(&summary.run_folder);
            Ok(summary.steps_per_wall_sec)
        }
    }
}

/// Runs the benchmark for each snake size; `duration_secs` of simulated time per measurement.
/// Each mode is measured `repeats` times, interleaved with the others (so that a slow spell of
/// the machine hits all modes alike), and the fastest measurement is reported.
pub fn run_bench(
    base: &Config,
    sizes: &[usize],
    duration_secs: f64,
    output_dir: &str,
    repeats: usize,
) -> Result<Vec<BenchRow>, RunError> {
    let mut rows = Vec::new();
    for &n_links in sizes {
        let mut config = base.clone();
        config.snake.n_links = n_links;
        config.general.duration_secs = duration_secs;
        config.general.output_dir = output_dir.to_string();
        config.general.run_name = format!("bench-{n_links}");
        let steps = (duration_secs / config.general.timestep_secs).round() as u64;
        let modes = modes();
        let mut best = vec![0.0f64; modes.len()];
        for _ in 0..repeats.max(1) {
            for (mode, best) in modes.iter().zip(&mut best) {
                *best = best.max(measure(&config, mode, steps)?);
            }
        }
        for (mode, steps_per_sec) in modes.into_iter().zip(best) {
            rows.push(BenchRow { n_links, mode, steps, steps_per_sec });
        }
    }
    Ok(rows)
}

/// Full pipeline over the bare engine with the same gait ("bare, gait") for each full-pipeline
/// row of `rows`: `(n_links, mode, ratio)`.
pub fn pipeline_ratios(rows: &[BenchRow]) -> Vec<(usize, &'static str, f64)> {
    let bare_of = |n: usize| rows.iter().find(|r| r.n_links == n && r.mode == BARE_GAIT).map(|r| r.steps_per_sec);
    rows.iter()
        .filter(|r| r.mode == FULL_CSV || r.mode == FULL_PARQUET)
        .filter_map(|r| bare_of(r.n_links).map(|b| (r.n_links, r.mode, r.steps_per_sec / b)))
        .collect()
}

/// The benchmark as one JSON document (`simserpent bench --json`): the settings and, per
/// snake size and mode, steps per wall second and the ratio to the bare engine with the same
/// gait. A ratio, not a time, is what a regression guard on a shared machine compares.
pub fn to_json(config: &Config, duration_secs: f64, repeats: usize, rows: &[BenchRow]) -> serde_json::Value {
    let ratios = pipeline_ratios(rows);
    let rows: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let ratio = ratios.iter().find(|(n, m, _)| *n == r.n_links && *m == r.mode).map(|(_, _, x)| *x);
            serde_json::json!({
                "n_links": r.n_links,
                "mode": r.mode,
                "steps": r.steps,
                "steps_per_sec": r.steps_per_sec,
                "real_time_factor": r.steps_per_sec * config.general.timestep_secs,
                "ratio_to_bare_gait": ratio,
            })
        })
        .collect();
    serde_json::json!({
        "simserpent": env!("CARGO_PKG_VERSION"),
        "mujoco": crate::sim::engine_version(),
        "timestep_secs": config.general.timestep_secs,
        "integrator": format!("{:?}", config.general.integrator),
        "recording_every_n_steps": config.recording.every_n_steps,
        "duration_secs": duration_secs,
        "repeats": repeats,
        "rows": rows,
    })
}

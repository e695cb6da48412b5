//! `simserpent bench`: steps per second of the bare engine against the full pipeline.
//!
//! For each snake size the same generated model (default config: lateral undulation through the
//! position servos, cylinder path, RK4, 1 ms) is stepped three ways:
//! - **bare, still**: `mj_step` only, controls left at zero (no controller, no read-out, no
//!   recording) — the "bare engine";
//! - **bare, gait**: `mj_step` with the sine-wave set-points written straight into `ctrl`, nothing
//!   else — the (20) baseline;
//! - **bare, gait + ground**: the same plus SimSerpent's ground model before each step
//!   ([`Ground::before_step`]: with the default `physics.floor_friction = "stick_slip"` it computes
//!   the floor friction forces and writes them into `xfrc_applied`). That is physics the full run
//!   always does, recorded or not, so full pipeline / this mode is the cost of recording alone;
//! - **full (no tables)**: `run::run` with `recording.enabled = false`: controller, ground
//!   model, the read-out at the recorded instants (for the run summary) and the run folder, but
//!   no tables and so no writer thread — separates the pipeline's cost from the tables';
//! - **full (CSV)**: `run::run` — controller, sensor noise model, read-out, CSV recording of
//!   every table at the configured interval, run folder and manifest;
//! - **full (Parquet)**: the same, recording Parquet tables instead (feature `parquet`);
//! - **full (MCAP)**: the same, writing only the ROS 2 bag (`run.mcap`) instead;
//! - with `--inline-writers`, also **full (CSV / Parquet / MCAP, writers inline)**: the same
//!   runs with the files formatted and written on the step-loop thread
//!   ([`RunOptions::inline_writers`], the synchronous path) instead of on writer threads —
//!   measured interleaved with the others, so the two paths are compared in one process.
//!
//! "Bare, gait" was the baseline of issue 20 and its CI guard; since the own floor friction model
//! (issue 14) became the default, it simulates cheaper physics than the run does (no floor
//! friction forces), so both ratios are reported: to "bare, gait" (the guard, unchanged) and to
//! "bare, gait + ground" (the same physics: what recording and control cost).
//!
//! Wall time only counts the stepping (model compilation is excluded in all three).

use crate::config::{Config, ControlMethod, TableFormat};
use crate::control::{JointTrajectory, trajectory_from_config};
use crate::run::{self, RunError, RunOptions};
use crate::sim::{Ground, SimError, World};
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

fn bare(config: &Config, steps: u64, with_gait: bool, with_ground: bool) -> Result<f64, SimError> {
    let mut world = World::from_config(config)?;
    let mut ground = with_ground.then(|| Ground::new(config, &world));
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
        if let Some(ground) = ground.as_mut() {
            ground.before_step(&mut world);
        }
        world.step();
    }
    Ok(steps as f64 / start.elapsed().as_secs_f64())
}

/// The modes measured per snake size, in output order; with `inline_writers` also the
/// full-pipeline modes with the writers on the step-loop thread.
pub fn modes(inline_writers: bool) -> Vec<&'static str> {
    let mut m = vec![BARE_STILL, BARE_GAIT, BARE_GAIT_GROUND, FULL_NONE, FULL_CSV];
    if cfg!(feature = "parquet") {
        m.push(FULL_PARQUET);
    }
    m.push(FULL_MCAP);
    if inline_writers {
        m.push(FULL_CSV_INLINE);
        if cfg!(feature = "parquet") {
            m.push(FULL_PARQUET_INLINE);
        }
        m.push(FULL_MCAP_INLINE);
    }
    m
}

/// `mj_step` only, controls at zero.
pub const BARE_STILL: &str = "bare, still";
/// `mj_step` with the gait written into `ctrl`: the baseline (a).
pub const BARE_GAIT: &str = "bare, gait";
/// "bare, gait" plus the ground model before each step: the same physics as the full run.
pub const BARE_GAIT_GROUND: &str = "bare, gait + ground";
/// `run::run` without tables (`recording.enabled = false`).
pub const FULL_NONE: &str = "full pipeline (no tables)";
/// `run::run` recording CSV tables (b).
pub const FULL_CSV: &str = "full pipeline (CSV)";
/// `run::run` recording Parquet tables (c).
pub const FULL_PARQUET: &str = "full pipeline (Parquet)";
/// `run::run` writing only the ROS 2 bag (`run.mcap`, README "ROS 2").
pub const FULL_MCAP: &str = "full pipeline (MCAP)";
/// [`FULL_CSV`] with the writers on the step-loop thread.
pub const FULL_CSV_INLINE: &str = "full pipeline (CSV, writers inline)";
/// [`FULL_PARQUET`] with the writers on the step-loop thread.
pub const FULL_PARQUET_INLINE: &str = "full pipeline (Parquet, writers inline)";
/// [`FULL_MCAP`] with the writers on the step-loop thread.
pub const FULL_MCAP_INLINE: &str = "full pipeline (MCAP, writers inline)";

fn measure(config: &Config, mode: &str, steps: u64) -> Result<f64, RunError> {
    match mode {
        BARE_STILL => Ok(bare(config, steps, false, false)?),
        BARE_GAIT => Ok(bare(config, steps, true, false)?),
        BARE_GAIT_GROUND => Ok(bare(config, steps, true, true)?),
        _ => {
            let mut config = config.clone();
            config.recording.enabled = mode != FULL_NONE;
            config.recording.format = match mode {
                FULL_PARQUET | FULL_PARQUET_INLINE => TableFormat::Parquet,
                FULL_MCAP | FULL_MCAP_INLINE => TableFormat::Mcap,
                _ => TableFormat::Csv,
            };
            let inline_writers = matches!(mode, FULL_CSV_INLINE | FULL_PARQUET_INLINE | FULL_MCAP_INLINE);
            let options = RunOptions { config_source: "bench".into(), inline_writers, ..RunOptions::default() };
            let summary = run::run(&config, &options)?;
            // Only the last folder of each mode is kept: benches should not fill the disk.
            let _ = std::fs::remove_dir_all(&summary.run_folder);
            Ok(summary.steps_per_wall_sec)
        }
    }
}

/// Runs the benchmark for each snake size; `duration_secs` of simulated time per measurement
/// (`inline_writers`: also the modes of [`modes`] with the writers inline).
/// Each mode is measured `repeats` times, interleaved with the others (so that a slow spell of
/// the machine hits all modes alike), and the fastest measurement is reported.
pub fn run_bench(
    base: &Config,
    sizes: &[usize],
    duration_secs: f64,
    output_dir: &str,
    repeats: usize,
    inline_writers: bool,
) -> Result<Vec<BenchRow>, RunError> {
    let mut rows = Vec::new();
    for &n_links in sizes {
        let mut config = base.clone();
        config.snake.n_links = n_links;
        config.general.duration_secs = duration_secs;
        config.general.output_dir = output_dir.to_string();
        config.general.run_name = format!("bench-{n_links}");
        let steps = (duration_secs / config.general.timestep_secs).round() as u64;
        let modes = modes(inline_writers);
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
/// row of `rows`: `(n_links, mode, ratio)`. The CI guard (`--min-ratio`) compares these.
pub fn pipeline_ratios(rows: &[BenchRow]) -> Vec<(usize, &'static str, f64)> {
    ratios_to(rows, BARE_GAIT)
}

/// Full pipeline over "bare, gait + ground" (the same physics as the run) for each
/// full-pipeline row: what recording (and the controller) cost on top of the physics.
pub fn same_physics_ratios(rows: &[BenchRow]) -> Vec<(usize, &'static str, f64)> {
    ratios_to(rows, BARE_GAIT_GROUND)
}

fn ratios_to(rows: &[BenchRow], baseline: &str) -> Vec<(usize, &'static str, f64)> {
    let bare_of = |n: usize| rows.iter().find(|r| r.n_links == n && r.mode == baseline).map(|r| r.steps_per_sec);
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
    let same_physics = same_physics_ratios(rows);
    let find = |list: &[(usize, &str, f64)], r: &BenchRow| {
        list.iter().find(|(n, m, _)| *n == r.n_links && *m == r.mode).map(|(_, _, x)| *x)
    };
    let rows: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let ratio = find(&ratios, r);
            let ratio_same_physics = find(&same_physics, r);
            serde_json::json!({
                "n_links": r.n_links,
                "mode": r.mode,
                "steps": r.steps,
                "steps_per_sec": r.steps_per_sec,
                "real_time_factor": r.steps_per_sec * config.general.timestep_secs,
                "ratio_to_bare_gait": ratio,
                "ratio_to_bare_gait_ground": ratio_same_physics,
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

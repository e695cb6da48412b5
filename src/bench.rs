//! `simserpent bench`: steps per second of the bare engine against the full pipeline.
//!
//! For each snake size the same generated model (default config: lateral undulation through the
//! position servos, cylinder path, RK4, 1 ms) is stepped three ways:
//! - **bare, still**: `mj_step` only, controls left at zero (no controller, no read-out, no
//!   recording) — the "bare engine";
//! - **bare, gait**: `mj_step` with the sine-wave set-points written straight into `ctrl` — the
//!   same motion and contacts as the full run, with nothing else;
//! - **full**: `run::run` — controller, sensor noise model, read-out, CSV recording of every
//!   table at the configured interval, run folder and manifest.
//!
//! Wall time only counts the stepping (model compilation is excluded in all three).

use crate::config::Config;
use crate::control::{JointTrajectory, trajectory_from_config};
use crate::model::names;
use crate::run::{self, RunError, RunOptions};
use crate::sim::{SimError, World};
use mujoco_rs::prelude::MjtObjBase;
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
    let actuator_ids: Vec<usize> = (1..=n)
        .filter_map(|j| world.model.name_to_id(MjtObjBase::mjOBJ_ACTUATOR, &names::actuator(config.control.method, j)))
        .collect();
    let (mut angle, mut velocity) = (vec![0.0; n], vec![0.0; n]);
    let dt = config.general.timestep_secs;
    let start = Instant::now();
    for k in 0..steps {
        if with_gait {
            trajectory.targets(k as f64 * dt, &mut angle, &mut velocity);
            let ctrl = world.data.ctrl_mut();
            for (a, target) in actuator_ids.iter().zip(&angle) {
                ctrl[*a] = *target;
            }
        }
        world.data.step();
    }
    Ok(steps as f64 / start.elapsed().as_secs_f64())
}

/// Runs the benchmark for each snake size; `duration_secs` of simulated time per measurement.
pub fn run_bench(
    base: &Config,
    sizes: &[usize],
    duration_secs: f64,
    output_dir: &str,
) -> Result<Vec<BenchRow>, RunError> {
    let mut rows = Vec::new();
    for &n_links in sizes {
        let mut config = base.clone();
        config.snake.n_links = n_links;
        config.general.duration_secs = duration_secs;
        config.general.output_dir = output_dir.to_string();
        config.general.run_name = format!("bench-{n_links}");
        let steps = (duration_secs / config.general.timestep_secs).round() as u64;
        rows.push(BenchRow { n_links, mode: "bare, still", steps, steps_per_sec: bare(&config, steps, false)? });
        rows.push(BenchRow { n_links, mode: "bare, gait", steps, steps_per_sec: bare(&config, steps, true)? });
        let summary = run::run(&config, &RunOptions { config_source: "bench".into(), ..RunOptions::default() })?;
        rows.push(BenchRow { n_links, mode: "full pipeline (CSV)", steps, steps_per_sec: summary.steps_per_wall_sec });
    }
    Ok(rows)
}

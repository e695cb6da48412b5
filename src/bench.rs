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
//! - built with the cargo feature `ros2`, also **full (MCAP + ROS 2 bridge)**: the same with the
//!   live bridge of `run --ros2` publishing every topic over DDS (free clock, as fast as it goes:
//!   `ros2.real_time_factor = 0`; on loopback only: `ros2.interfaces = ["127.0.0.1"]`; the rest
//!   of `[ros2]` as configured, e.g. `--set ros2.publish_rate_hz=1000` for every step) — the
//!   bridge's encoding and writing run on the step-loop thread, RustDDS's sending on its own.
//!   Nobody sends commands, so the joints hold zero instead of following the gait: the physics
//!   differs a little from the other full modes (compare the bridge's cost between builds);
//! - with `--inline-writers`, also **full (CSV / Parquet / MCAP, writers inline)**: the same
//!   runs with the files formatted and written on the step-loop thread
//!   ([`RunOptions::inline_writers`], the synchronous path) instead of on writer threads —
//!   measured interleaved with the others, so the two paths are compared in one process.
//!
//! "Bare, gait" is the baseline of the CI guard; with SimSerpent's own floor friction model (the
//! default) the run simulates more physics than it does (the floor friction forces), so both
//! ratios are reported: to "bare, gait" (the guard, unchanged) and to
//! "bare, gait + ground" (the same physics: what recording and control cost).
//!
//! - with `--discard-rows`, also **full (CSV, rows discarded)**: the CSV run with writer threads
//!   that receive the rows and drop them unwritten (a dummy sink): the step loop does exactly
//!   the work of "full (CSV)", the writer threads almost none — so the step-loop thread's CPU
//!   time in the two modes shows how much a busy writer thread slows the loop through the shared
//!   caches and memory.
//!
//! Wall time only counts the stepping (model compilation is excluded in all three).
//!
//! Besides wall time every row has the **CPU time per step** of the step-loop thread and,
//! summed, of the writer threads (`CLOCK_THREAD_CPUTIME_ID`, [`crate::cpu_time`]), and how often
//! and how long the step loop waited for a writer thread. CPU time does not count time spent
//! waiting for a core, so the ratio of the step-loop thread's CPU time per step, bare engine
//! over full pipeline (`cpu_ratio_to_bare_gait` in `--json`), does not fall when other
//! processes load the machine, unlike the wall ratio; it does not count the writer threads
//! either (they are reported beside it).

use crate::config::{Config, ControlMethod, TableFormat};
use crate::control::{JointTrajectory, trajectory_from_config};
use crate::cpu_time::thread_cpu_ns;
use crate::record::offload::{WriterAccount, account_writers};
use crate::run::{self, RunError, RunOptions};
use crate::sim::{Ground, SimError, World};
use std::sync::Arc;
use std::time::Instant;

/// One measurement of one mode.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Measured {
    /// Steps per wall second.
    pub steps_per_sec: f64,
    /// CPU time of the step-loop thread per step (ns), over the same interval.
    pub loop_cpu_ns_per_step: f64,
    /// CPU time of all writer threads per step (ns), summed over the threads and their whole
    /// life (including the rows written after the loop ended); 0 without writer threads.
    pub writer_cpu_ns_per_step: f64,
    /// Writer threads.
    pub writer_threads: u64,
    /// Times the step loop waited for a writer thread (no free batch, or a flush).
    pub loop_waits: u64,
    /// Wall time of those waits (s).
    pub loop_wait_secs: f64,
    /// The longest CPU time a writer thread spent on one batch of rows (s; see
    /// [`crate::record::offload::WriterTotals::longest_batch_ns`]).
    pub writer_longest_batch_secs: f64,
}

/// One measured row: the fastest of the repeats (wall), and the CPU times of every repeat.
#[derive(Debug, Clone)]
pub struct BenchRow {
    /// Links.
    pub n_links: usize,
    /// What was measured.
    pub mode: &'static str,
    /// Steps taken.
    pub steps: u64,
    /// Steps per wall second (the fastest repeat).
    pub steps_per_sec: f64,
    /// The fastest repeat (by wall time), whole.
    pub fastest: Measured,
    /// Every repeat, in order.
    pub repeats: Vec<Measured>,
}

impl BenchRow {
    /// The step-loop thread's CPU time per step, least over the repeats (ns): the least
    /// disturbed measurement, as the fastest wall time is.
    pub fn loop_cpu_ns_per_step(&self) -> f64 {
        self.repeats.iter().map(|m| m.loop_cpu_ns_per_step).fold(f64::INFINITY, f64::min)
    }

    /// The writer threads' CPU time per step, least over the repeats (ns).
    pub fn writer_cpu_ns_per_step(&self) -> f64 {
        self.repeats.iter().map(|m| m.writer_cpu_ns_per_step).fold(f64::INFINITY, f64::min)
    }

    /// Waits of the step loop for a writer thread, summed over the repeats, and their wall time (s).
    pub fn loop_waits(&self) -> (u64, f64) {
        self.repeats.iter().fold((0, 0.0), |(n, s), m| (n + m.loop_waits, s + m.loop_wait_secs))
    }
}

fn bare(config: &Config, steps: u64, with_gait: bool, with_ground: bool) -> Result<Measured, SimError> {
    let mut world = World::from_config(config)?;
    let mut ground = with_ground.then(|| Ground::new(config, &world));
    let trajectory: Box<dyn JointTrajectory> = trajectory_from_config(config);
    let n = world.n_joints();
    let kind = ControlMethod::ALL.iter().position(|m| *m == config.control.method).unwrap_or(0);
    let actuator_ids: Vec<usize> = world.index.joints.iter().filter_map(|j| j.actuators[kind]).collect();
    let (mut angle, mut velocity) = (vec![0.0; n], vec![0.0; n]);
    let dt = config.general.timestep_secs;
    let start = Instant::now();
    let cpu_start = thread_cpu_ns();
    for k in 0..steps {
        if k % crate::interrupt::CHECK_EVERY_N_STEPS == 0 {
            crate::interrupt::check(|| format!("at step {k} of the bare-engine measurement"))?;
        }
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
    let cpu_ns = thread_cpu_ns().saturating_sub(cpu_start) as f64;
    let wall = start.elapsed().as_secs_f64();
    Ok(Measured {
        steps_per_sec: steps as f64 / wall,
        loop_cpu_ns_per_step: cpu_ns / steps as f64,
        ..Measured::default()
    })
}

/// The modes measured per snake size, in output order; with `inline_writers` also the
/// full-pipeline modes with the writers on the step-loop thread, with `discard_rows` also
/// [`FULL_CSV_DISCARD`].
pub fn modes(inline_writers: bool, discard_rows: bool) -> Vec<&'static str> {
    let mut m = vec![BARE_STILL, BARE_GAIT, BARE_GAIT_GROUND, FULL_NONE, FULL_CSV];
    if cfg!(feature = "parquet") {
        m.push(FULL_PARQUET);
    }
    m.push(FULL_MCAP);
    if cfg!(feature = "ros2") {
        m.push(FULL_MCAP_ROS2);
    }
    if inline_writers {
        m.push(FULL_CSV_INLINE);
        if cfg!(feature = "parquet") {
            m.push(FULL_PARQUET_INLINE);
        }
        m.push(FULL_MCAP_INLINE);
    }
    if discard_rows {
        m.push(FULL_CSV_DISCARD);
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
/// `run::run` writing only the ROS 2 bag (`run.mcap`, user guide, "ROS 2").
pub const FULL_MCAP: &str = "full pipeline (MCAP)";
/// [`FULL_MCAP`] with the live ROS 2 bridge publishing (cargo feature `ros2`).
pub const FULL_MCAP_ROS2: &str = "full pipeline (MCAP + ROS 2 bridge)";
/// [`FULL_CSV`] with writer threads that drop the rows unwritten (a dummy sink).
pub const FULL_CSV_DISCARD: &str = "full pipeline (CSV, rows discarded)";
/// [`FULL_CSV`] with the writers on the step-loop thread.
pub const FULL_CSV_INLINE: &str = "full pipeline (CSV, writers inline)";
/// [`FULL_PARQUET`] with the writers on the step-loop thread.
pub const FULL_PARQUET_INLINE: &str = "full pipeline (Parquet, writers inline)";
/// [`FULL_MCAP`] with the writers on the step-loop thread.
pub const FULL_MCAP_INLINE: &str = "full pipeline (MCAP, writers inline)";

fn measure(config: &Config, mode: &str, steps: u64) -> Result<Measured, RunError> {
    match mode {
        BARE_STILL => Ok(bare(config, steps, false, false)?),
        BARE_GAIT => Ok(bare(config, steps, true, false)?),
        BARE_GAIT_GROUND => Ok(bare(config, steps, true, true)?),
        _ => {
            let mut config = config.clone();
            config.recording.enabled = mode != FULL_NONE;
            config.recording.format = match mode {
                FULL_PARQUET | FULL_PARQUET_INLINE => TableFormat::Parquet,
                FULL_MCAP | FULL_MCAP_INLINE | FULL_MCAP_ROS2 => TableFormat::Mcap,
                _ => TableFormat::Csv,
            };
            let ros2 = mode == FULL_MCAP_ROS2;
            if ros2 {
                config.ros2.clock = crate::config::Ros2Clock::Free;
                config.ros2.real_time_factor = 0.0;
                config.ros2.interfaces = vec!["127.0.0.1".to_string()];
            }
            let inline_writers = writers_inline(mode);
            let options = RunOptions { config_source: "bench".into(), inline_writers, ros2, ..RunOptions::default() };
            let account = Arc::new(WriterAccount::new(mode == FULL_CSV_DISCARD));
            let summary = {
                let _accounting = account_writers(account.clone());
                run::run(&config, &options)?
            };
            // Only the last folder of each mode is kept: benches should not fill the disk.
            let _ = std::fs::remove_dir_all(&summary.run_folder);
            let writers = account.totals();
            let per_step = |x: f64| x / steps.max(1) as f64;
            Ok(Measured {
                steps_per_sec: summary.steps_per_wall_sec,
                loop_cpu_ns_per_step: per_step(summary.loop_cpu_secs * 1e9),
                writer_cpu_ns_per_step: per_step(writers.cpu_ns as f64),
                writer_threads: writers.threads,
                loop_waits: writers.waits,
                loop_wait_secs: writers.wait_ns as f64 * 1e-9,
                writer_longest_batch_secs: writers.longest_batch_ns as f64 * 1e-9,
            })
        }
    }
}

/// Runs the benchmark for each snake size; `duration_secs` of simulated time per measurement
/// (`inline_writers`, `discard_rows`: also those modes of [`modes`]).
/// Each mode is measured `repeats` times, interleaved with the others (so that a slow spell of
/// the machine hits all modes alike), and the fastest measurement is reported.
pub fn run_bench(
    base: &Config,
    sizes: &[usize],
    duration_secs: f64,
    output_dir: &str,
    repeats: usize,
    inline_writers: bool,
    discard_rows: bool,
) -> Result<Vec<BenchRow>, RunError> {
    // Every size's config is checked before the first measurement.
    let configs = sizes
        .iter()
        .map(|&n_links| bench_config(base, n_links, duration_secs, output_dir))
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::new();
    for (&n_links, config) in sizes.iter().zip(configs) {
        let steps = (duration_secs / config.general.timestep_secs).round() as u64;
        let modes = modes(inline_writers, discard_rows);
        let mut all: Vec<Vec<Measured>> = vec![Vec::new(); modes.len()];
        for _ in 0..repeats.max(1) {
            for (mode, all) in modes.iter().zip(&mut all) {
                crate::interrupt::check(|| format!("before the {n_links}-link {mode} measurement"))?;
                all.push(measure(&config, mode, steps)?);
            }
        }
        for (mode, repeats) in modes.into_iter().zip(all) {
            let fastest = repeats
                .iter()
                .copied()
                .fold(Measured::default(), |a, m| if m.steps_per_sec > a.steps_per_sec { m } else { a });
            rows.push(BenchRow { n_links, mode, steps, steps_per_sec: fastest.steps_per_sec, fastest, repeats });
        }
    }
    Ok(rows)
}

/// The config of one benchmark size. The sizes and the duration go through the config's own
/// bounds (at most 200 links, 1e9 steps per run), named as the arguments that set them.
fn bench_config(base: &Config, n_links: usize, duration_secs: f64, output_dir: &str) -> Result<Config, RunError> {
    use crate::config::ConfigError;
    let mut config = base.clone();
    config.snake.n_links = n_links;
    config.general.duration_secs = duration_secs;
    config.general.output_dir = output_dir.to_string();
    config.general.run_name = format!("bench-{n_links}");
    config.validate().map_err(|e| {
        let e = match e {
            ConfigError::InvalidValue { key, value, allowed } => ConfigError::InvalidValue {
                key: match key.as_str() {
                    "snake.n_links" => "--links (snake.n_links)".into(),
                    "general.duration_secs" => "--duration-secs (general.duration_secs)".into(),
                    _ => key,
                },
                value,
                allowed,
            },
            e => e,
        };
        RunError::Sim(SimError::Config(e))
    })?;
    Ok(config)
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

/// Whether `mode` writes its files on the step-loop thread (`--inline-writers`).
pub fn writers_inline(mode: &str) -> bool {
    matches!(mode, FULL_CSV_INLINE | FULL_PARQUET_INLINE | FULL_MCAP_INLINE)
}

/// The row of `mode` at `n_links` links.
fn row_of<'a>(rows: &'a [BenchRow], n_links: usize, mode: &str) -> Option<&'a BenchRow> {
    rows.iter().find(|r| r.n_links == n_links && r.mode == mode)
}

fn ratios_to(rows: &[BenchRow], baseline: &str) -> Vec<(usize, &'static str, f64)> {
    let bare_of = |n: usize| row_of(rows, n, baseline).map(|r| r.steps_per_sec);
    rows.iter()
        .filter(|r| r.mode == FULL_CSV || r.mode == FULL_PARQUET)
        .filter_map(|r| bare_of(r.n_links).map(|b| (r.n_links, r.mode, r.steps_per_sec / b)))
        .collect()
}

/// The step-loop thread's CPU time per step, `baseline` over each full-pipeline CSV/Parquet
/// row (least over the repeats each): `(n_links, mode, ratio)`. 1 means the loop thread of the
/// full pipeline needs no more CPU per step than the bare engine; it is not lowered by other
/// processes waiting for the cores (see the module documentation).
pub fn cpu_ratios(rows: &[BenchRow], baseline: &str) -> Vec<(usize, &'static str, f64)> {
    let bare_of = |n: usize| row_of(rows, n, baseline).map(BenchRow::loop_cpu_ns_per_step);
    rows.iter()
        .filter(|r| r.mode == FULL_CSV || r.mode == FULL_PARQUET)
        .filter_map(|r| bare_of(r.n_links).map(|b| (r.n_links, r.mode, b / r.loop_cpu_ns_per_step())))
        .collect()
}

/// The share of the recording's CPU work that the step-loop thread does, for each full-pipeline
/// row that records tables (CSV, Parquet, MCAP, and their writers-inline rows):
/// `(n_links, mode, share)` with
/// share = Δ / (Δ + W), Δ the step loop's CPU time per step above "full pipeline (no tables)"
/// (0 when below) and W the writer threads' CPU time per step, least over the repeats each.
/// About 0 when the writer threads format and write the files, 1 when the loop does it itself
/// (no writer threads). Unlike [`cpu_ratios`] it does not divide by the bare engine, whose CPU
/// time per step on a virtual machine can vary by more than half between repeats.
pub fn loop_shares(rows: &[BenchRow]) -> Vec<(usize, &'static str, f64)> {
    let none_of = |n: usize| row_of(rows, n, FULL_NONE).map(BenchRow::loop_cpu_ns_per_step);
    rows.iter()
        .filter(|r| matches!(r.mode, FULL_CSV | FULL_PARQUET | FULL_MCAP) || writers_inline(r.mode))
        .filter_map(|r| {
            none_of(r.n_links).map(|none| {
                let delta = (r.loop_cpu_ns_per_step() - none).max(0.0);
                let writers = if r.fastest.writer_threads == 0 { 0.0 } else { r.writer_cpu_ns_per_step() };
                let share = if delta + writers > 0.0 { delta / (delta + writers) } else { 0.0 };
                (r.n_links, r.mode, share)
            })
        })
        .collect()
}

/// How many rows the step loop can run ahead of the tables' writer thread in `mode`.
fn lead_rows(mode: &str) -> usize {
    use crate::record::{BATCH, PARQUET_POOL, offload::POOL};
    if matches!(mode, FULL_PARQUET | FULL_PARQUET_INLINE) { PARQUET_POOL * BATCH } else { POOL * BATCH }
}

/// The benchmark as one JSON document (`simserpent bench --json`): the settings and, per
/// snake size and mode, steps per wall second and the ratio to the bare engine with the same
/// gait. A ratio, not a time, is what a regression guard on a shared machine compares.
pub fn to_json(config: &Config, duration_secs: f64, repeats: usize, rows: &[BenchRow]) -> serde_json::Value {
    let ratios = pipeline_ratios(rows);
    let same_physics = same_physics_ratios(rows);
    let cpu = cpu_ratios(rows, BARE_GAIT);
    let cpu_same_physics = cpu_ratios(rows, BARE_GAIT_GROUND);
    let shares = loop_shares(rows);
    let find = |list: &[(usize, &str, f64)], r: &BenchRow| {
        list.iter().find(|(n, m, _)| *n == r.n_links && *m == r.mode).map(|(_, _, x)| *x)
    };
    let rows: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let ratio = find(&ratios, r);
            let ratio_same_physics = find(&same_physics, r);
            let us = |ns: f64| ns * 1e-3;
            let (waits, wait_secs) = r.loop_waits();
            serde_json::json!({
                "n_links": r.n_links,
                "mode": r.mode,
                "steps": r.steps,
                "steps_per_sec": r.steps_per_sec,
                "real_time_factor": r.steps_per_sec * config.general.timestep_secs,
                "ratio_to_bare_gait": ratio,
                "ratio_to_bare_gait_ground": ratio_same_physics,
                "loop_cpu_us_per_step": us(r.loop_cpu_ns_per_step()),
                "writer_cpu_us_per_step": us(r.writer_cpu_ns_per_step()),
                "writer_threads": r.fastest.writer_threads,
                "wall_us_per_step": 1e6 / r.steps_per_sec,
                "cpu_ratio_to_bare_gait": find(&cpu, r),
                "cpu_ratio_to_bare_gait_ground": find(&cpu_same_physics, r),
                "loop_share_of_recording": find(&shares, r),
                "loop_waits": waits,
                "loop_wait_secs": wait_secs,
                "writer_longest_batch_ms": r.repeats.iter().map(|m| m.writer_longest_batch_secs * 1e3).fold(0.0, f64::max),
                "loop_lead_ms": (r.fastest.writer_threads > 0).then(|| us(r.loop_cpu_ns_per_step()) * 1e-3 * lead_rows(r.mode) as f64),
                "repeats": r.repeats.iter().map(|m| serde_json::json!({
                    "steps_per_sec": m.steps_per_sec,
                    "loop_cpu_us_per_step": us(m.loop_cpu_ns_per_step),
                    "writer_cpu_us_per_step": us(m.writer_cpu_ns_per_step),
                    "loop_waits": m.loop_waits,
                    "loop_wait_secs": m.loop_wait_secs,
                    "writer_longest_batch_ms": m.writer_longest_batch_secs * 1e3,
                })).collect::<Vec<_>>(),
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

#[cfg(test)]
mod tests {
    use super::*;

    fn row(mode: &'static str, loop_ns: &[f64], writer_ns: f64, writer_threads: u64) -> BenchRow {
        let repeats: Vec<Measured> = loop_ns
            .iter()
            .map(|&l| Measured {
                steps_per_sec: 1e9 / l,
                loop_cpu_ns_per_step: l,
                writer_cpu_ns_per_step: writer_ns,
                writer_threads,
                ..Measured::default()
            })
            .collect();
        BenchRow {
            n_links: 10,
            mode,
            steps: 1000,
            steps_per_sec: repeats[0].steps_per_sec,
            fastest: repeats[0],
            repeats,
        }
    }

    /// The share is Δ / (Δ + W) on the least CPU times: writers that do the formatting give a
    /// small share, a loop below the pipeline without tables gives 0, no writer threads give 1.
    #[test]
    fn the_loop_share_of_the_recording_follows_its_definition() {
        let rows = [
            row(FULL_NONE, &[60_000.0, 50_000.0], 0.0, 0),
            row(FULL_CSV, &[90_000.0, 70_000.0], 80_000.0, 2),
            row(FULL_MCAP, &[45_000.0], 150_000.0, 2),
            row(FULL_CSV_INLINE, &[150_000.0], 0.0, 0),
            row(BARE_GAIT_GROUND, &[40_000.0], 0.0, 0),
        ];
        let shares = loop_shares(&rows);
        let share = |mode: &str| shares.iter().find(|(_, m, _)| *m == mode).map(|(_, _, s)| *s);
        assert!((share(FULL_CSV).expect("a CSV share") - 20_000.0 / 100_000.0).abs() < 1e-12, "{shares:?}");
        assert_eq!(share(FULL_MCAP), Some(0.0));
        assert_eq!(share(FULL_CSV_INLINE), Some(1.0));
        assert_eq!(share(BARE_GAIT_GROUND), None);
        assert_eq!(share(FULL_NONE), None);
    }
}

//! Execution: runs in parallel on a rayon pool, restarts that skip finished runs, and the
//! outcome of each run.

use super::plan::{PlannedRun, default_sweep_dir, plan, set_arg, write_plan};
use super::spec::SweepSpec;
use super::summary::{SummaryTable, write_summary};
use super::{SweepError, io_error};
use crate::record::{Manifest, RunStatus};
use crate::run::{self, RunOptions};
use rayon::prelude::*;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;
use toml::Value;

pub use super::summary::{RunOutcome, SkippedSummary, SweepRow};

/// The result of [`run_sweep`].
#[derive(Debug, Clone)]
pub struct SweepReport {
    /// The sweep folder.
    pub sweep_dir: PathBuf,
    /// The summary file written (CSV).
    pub summary_csv: PathBuf,
    /// Rows of this shard, in plan order.
    pub rows: Vec<SweepRow>,
    /// Wall time of this invocation (s).
    pub wall_secs: f64,
    /// Worker threads used.
    pub threads: usize,
}

impl SweepReport {
    /// Runs that completed now, were skipped as done earlier, and failed (interrupted runs
    /// are in none of these: see [`SweepReport::interrupted`]).
    pub fn counts(&self) -> (usize, usize, usize) {
        let mut c = (0, 0, 0);
        for r in &self.rows {
            match r.outcome {
                RunOutcome::Complete(_) => c.0 += 1,
                RunOutcome::Skipped(_) => c.1 += 1,
                RunOutcome::Failed(_) => c.2 += 1,
                RunOutcome::Interrupted(_) => {}
            }
        }
        c
    }

    /// Runs stopped or not started because of SIGINT/SIGTERM.
    pub fn interrupted(&self) -> usize {
        self.rows.iter().filter(|r| matches!(r.outcome, RunOutcome::Interrupted(_))).count()
    }
}

/// Whether `folder/manifest.json` says the run completed; then its summary. A manifest that
/// cannot be read as a [`Manifest`] is not a finished run: the run is redone.
fn finished(folder: &Path) -> Option<SkippedSummary> {
    let manifest = Manifest::read(folder)?;
    if manifest.status != RunStatus::Complete {
        return None;
    }
    Some(SkippedSummary { summary: manifest.summary, wall_secs: manifest.wall_time_secs })
}

fn run_one(spec: &SweepSpec, run: &PlannedRun, folder: &Path, command_line: &[String]) -> RunOutcome {
    // A link at a run's name is neither read as a finished run nor written through.
    if std::fs::symlink_metadata(folder).is_ok_and(|m| m.file_type().is_symlink()) {
        return RunOutcome::Failed(crate::files::FileError::Link { path: folder.to_path_buf() }.to_string());
    }
    if let Some(done) = finished(folder) {
        return RunOutcome::Skipped(done);
    }
    if crate::interrupt::requested() {
        return RunOutcome::Interrupted("not started: the sweep was interrupted".into());
    }
    let mut extra: Vec<String> = run.params.iter().map(|(k, v)| set_arg(k, v)).collect();
    extra.push(set_arg("general.run_name", &Value::String(run.id.clone())));
    let config = match spec.load_base(&extra) {
        Ok(c) => c,
        Err(e) => return RunOutcome::Failed(format!("config: {e}")),
    };
    // A failed or interrupted earlier attempt: start from an empty folder.
    if folder.exists()
        && let Err(e) = std::fs::remove_dir_all(folder)
    {
        return RunOutcome::Failed(format!("cannot clear {}: {e}", folder.display()));
    }
    let options = RunOptions {
        config_source: format!(
            "{} + {}",
            spec.config_path.as_ref().map_or("embedded default".to_string(), |p| p.display().to_string()),
            extra.join(" ")
        ),
        command_line: command_line.to_vec(),
        run_folder: Some(folder.to_path_buf()),
        ..RunOptions::default()
    };
    match run::run(&config, &options) {
        Ok(summary) => RunOutcome::Complete(summary),
        Err(
            e @ (run::RunError::Interrupted { .. }
            | run::RunError::InterruptedSetUp
            | run::RunError::Plot(crate::plot::PlotError::Interrupted { .. })),
        ) => RunOutcome::Interrupted(e.to_string()),
        Err(e) => RunOutcome::Failed(e.to_string()),
    }
}

/// Runs a sweep (or one shard of it) and writes its summary.
///
/// # Errors
/// Bad arguments or base config; the sweep folder or summary cannot be written. Failing runs
/// are not errors.
pub fn run_sweep(spec: &SweepSpec) -> Result<SweepReport, SweepError> {
    if let Some(message) = crate::threads_beyond_cap("--threads", spec.threads) {
        return Err(super::argument("--threads", message));
    }
    let (sweep_dir, runs) = prepare(spec)?;
    let mine: Vec<&PlannedRun> = match spec.shard {
        Some(s) => runs.iter().filter(|r| r.index % s.count == s.index).collect(),
        None => runs.iter().collect(),
    };
    let mut builder = rayon::ThreadPoolBuilder::new();
    if spec.threads > 0 {
        builder = builder.num_threads(spec.threads);
    }
    let pool = builder.build().map_err(|source| SweepError::Threads { threads: spec.threads, source })?;
    let threads = pool.current_num_threads();
    let bar = progress_bar(spec.progress, mine.len() as u64);
    let failed = AtomicUsize::new(0);
    let command_line: Vec<String> = std::env::args().collect();
    let started = Instant::now();
    let rows: Vec<SweepRow> = pool.install(|| {
        mine.par_iter()
            .with_max_len(1)
            .map(|run| {
                let row = run_planned(spec, run, &sweep_dir, &command_line);
                if let RunOutcome::Failed(message) = &row.outcome {
                    let n = failed.fetch_add(1, Ordering::Relaxed) + 1;
                    bar.set_message(format!("{n} failed"));
                    log::debug!("sweep run {} failed: {message}", run.id);
                }
                bar.inc(1);
                row
            })
            .collect()
    });
    bar.finish_and_clear();
    let wall_secs = started.elapsed().as_secs_f64();
    let table = SummaryTable::from_rows(&spec.variations, &rows);
    let summary_csv = write_summary(spec, &sweep_dir, &table);
    unlock(&sweep_dir);
    let summary_csv = summary_csv?;
    Ok(SweepReport { sweep_dir, summary_csv, rows, wall_secs, threads })
}

/// Plans a sweep, creates its folder (`<sweep>/runs/`) and writes `sweep.json`: the first part
/// of [`run_sweep`], for drivers that run the planned runs elsewhere (the Python package's Ray
/// sweep runs each with [`run_planned`] in a Ray task and writes the summary with
/// [`write_summary`]).
///
/// # Errors
/// Bad arguments or base config; the sweep folder cannot be written.
pub fn prepare(spec: &SweepSpec) -> Result<(PathBuf, Vec<PlannedRun>), SweepError> {
    let (base, runs) = plan(spec)?;
    let sweep_dir = spec.sweep_dir.clone().unwrap_or_else(|| default_sweep_dir(spec, &base));
    std::fs::create_dir_all(&sweep_dir).map_err(io_error(&sweep_dir))?;
    // `runs/` is a real folder inside the sweep folder, never a link out of it (the writer rule
    // of `crate::files`).
    crate::files::create_dir_in(&sweep_dir, Path::new("runs"))?;
    lock(&sweep_dir, spec.shard)?;
    write_plan(spec, &sweep_dir, &runs)?;
    Ok((sweep_dir, runs))
}

/// The sweep folders' locks this process holds: (lock file, the open file holding the lock).
static LOCKS: std::sync::Mutex<Vec<(PathBuf, std::fs::File)>> = std::sync::Mutex::new(Vec::new());

/// Locks `sweep_dir` for this process (an advisory file lock, released when the process ends or
/// [`unlock`] is called): a whole sweep takes `.lock` exclusively; a shard takes `.lock` shared
/// and `.lock-shard-i-of-n` exclusively, so shards of one sweep run side by side while a second
/// copy of the same sweep or shard refuses at once.
///
/// # Errors
/// [`SweepError::Locked`] when another process holds the folder; I/O.
pub fn lock(sweep_dir: &Path, shard: Option<super::Shard>) -> Result<(), SweepError> {
    let mut wanted = vec![(sweep_dir.join(".lock"), shard.is_none())];
    if let Some(s) = shard {
        wanted.push((sweep_dir.join(format!(".lock-shard-{}-of-{}", s.index, s.count)), true));
    }
    let mut held = LOCKS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    for (path, exclusive) in wanted {
        if held.iter().any(|(p, _)| *p == path) {
            continue;
        }
        let file = crate::files::open_for_writing(&path, false)?;
        let locked = if exclusive { file.try_lock() } else { file.try_lock_shared() };
        if let Err(e) = locked {
            if let std::fs::TryLockError::Error(source) = e {
                return Err(SweepError::Io { path, source });
            }
            let what = match (shard, exclusive) {
                (Some(s), true) => format!("shard {}/{}", s.index, s.count),
                (Some(_), false) => "the whole sweep, not sharded".to_string(),
                (None, _) => "the same sweep or one of its shards".to_string(),
            };
            return Err(SweepError::Locked { folder: sweep_dir.to_path_buf(), what });
        }
        held.push((path, file));
    }
    Ok(())
}

/// Releases this process's locks of `sweep_dir` ([`lock`]).
pub fn unlock(sweep_dir: &Path) {
    let mut held = LOCKS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    held.retain(|(p, _)| p.parent() != Some(sweep_dir));
}

/// Runs one planned run into `<sweep_dir>/runs/<id>/` (or reads it back if a manifest says it
/// is complete). A failing run is a row with its error, not an error.
pub fn run_planned(spec: &SweepSpec, run: &PlannedRun, sweep_dir: &Path, command_line: &[String]) -> SweepRow {
    let folder = sweep_dir.join("runs").join(&run.id);
    let t0 = Instant::now();
    let outcome = run_one(spec, run, &folder, command_line);
    let wall_secs = t0.elapsed().as_secs_f64();
    SweepRow { run: run.clone(), outcome, folder, wall_secs }
}

fn progress_bar(enabled: bool, total: u64) -> indicatif::ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(total);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} elapsed, ETA {eta} {msg}")
    {
        bar.set_style(style);
    }
    bar
}

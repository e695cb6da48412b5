//! The thesis' experiments (chapter 7) and more, as commands with physics checks.
//!
//! `simserpent experiment <name>` creates `runs/experiment-<name>-<UTC time>/` holding one run
//! folder per case (data and plots, PNG and SVG) and `report.md`: what was run,
//! with which contact settings, a table of the measured numbers and every physics check with its
//! measured value, expected value, tolerance and pass/fail. The command exits 0 when every check
//! passes and 1 otherwise.

pub mod bounce;
mod collision;
mod data;
pub mod estimation;
mod locomotion;
pub mod oal_bench;
mod pictures;
mod report;

pub use collision::{LAUNCH_SPEED_M_PER_S, case_bodies as collision_case_bodies};
pub use data::Table;
pub use locomotion::averaged_viscous_speed;
pub(crate) use locomotion::undulation_config as locomotion_undulation_config;
pub(crate) use locomotion::undulation_coulomb_cases as locomotion_undulation_coulomb_cases;
pub use report::{Check, Report, Section};

use crate::config::Config;
use crate::record;
use crate::run::{self, RunError, RunOptions};
use crate::sim::{Simulation, World};
use std::path::{Path, PathBuf};

/// Errors of an experiment.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExperimentError {
    /// A run failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A run's data could not be analysed.
    #[error("analysis: {0}")]
    Data(String),
    /// A file of the experiment could not be read or written.
    #[error("cannot {what} {}", path.display())]
    Io {
        /// "read" or "write".
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A file of a run folder is not one SimSerpent reads ([`crate::files`]).
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// An interrupt (SIGINT/SIGTERM, [`crate::interrupt`]) stopped the experiment between runs.
    #[error("interrupted after {done} of {planned} runs")]
    Interrupted {
        /// Runs finished.
        done: usize,
        /// Runs planned.
        planned: usize,
    },
    /// No such experiment.
    #[error("unknown experiment `{0}`; available: {list}", list = NAMES.join(", "))]
    Unknown(String),
    /// An option the experiment does not take, or a bad value for one.
    #[error("{0}")]
    Option(String),
}

impl ExperimentError {
    /// Whether a signal (SIGINT/SIGTERM, or [`crate::interrupt::request`]) stopped the
    /// experiment (exit code 130).
    pub fn interrupted(&self) -> bool {
        use crate::sim::SimError;
        matches!(
            self,
            ExperimentError::Interrupted { .. }
                | ExperimentError::Run(
                    RunError::Interrupted { .. }
                        | RunError::InterruptedSetUp
                        | RunError::Sim(SimError::Interrupted { .. })
                        | RunError::Plot(crate::plot::PlotError::Interrupted { .. })
                )
        )
    }
}

/// Most seeds of `experiment estimation --seeds` (each is a peg-field run per floor).
pub const MAX_SEEDS: usize = 10_000;

/// The experiments, by command name.
pub const NAMES: [&str; 8] =
    ["configure", "collision", "undulation", "form-closure", "oal", "estimation", "bounce", "oal-bench"];

/// How an experiment runs: length of its runs, threads, progress.
#[derive(Debug, Clone, Default)]
pub struct ExperimentOptions {
    /// Shorter runs (for tests): fewer gait cycles, same checks.
    pub quick: bool,
    /// Worker threads for the cases (independent runs); 0: all cores.
    pub threads: usize,
    /// One line per finished case on stderr (name, wall time, how many are done).
    pub progress: bool,
    /// `estimation` only: the seeds of its peg-field runs (default 0–9, quick: 0).
    pub seeds: Option<Vec<u64>>,
    /// `estimation` only: run its peg-field runs on this floor only (isotropic or anisotropic;
    /// default both).
    pub floor: Option<crate::config::GroundModel>,
    /// `oal-bench` only: the benchmark's size, conditions and shard (default: [`oal_bench::Bench::full`]
    /// or, with `quick`, [`oal_bench::Bench::quick`]), or a merge of its shards.
    pub oal: Option<oal_bench::OalOptions>,
    /// Write into this folder (created if missing) instead of a new
    /// `<output_dir>/experiment-<name>-<UTC time>/`: where the shards of one `oal-bench` meet.
    pub folder: Option<PathBuf>,
}

/// Where an experiment writes, how long its runs are and where its cases run.
pub struct Context {
    /// The experiment folder.
    pub folder: PathBuf,
    /// Shorter runs (for tests): fewer gait cycles, same checks.
    pub quick: bool,
    /// The experiment's name (for progress lines).
    name: String,
    /// The threads the cases run on.
    pool: rayon::ThreadPool,
    /// Progress lines on stderr.
    progress: bool,
    /// [`ExperimentOptions::seeds`].
    pub seeds: Option<Vec<u64>>,
    /// [`ExperimentOptions::floor`].
    pub floor: Option<crate::config::GroundModel>,
    /// [`ExperimentOptions::oal`].
    pub oal: Option<oal_bench::OalOptions>,
}

impl Context {
    /// Runs the cases `(name, config)` as sub-runs ([`Context::sub_run`]) in parallel on the
    /// experiment's threads, after `prepare(case index, world)` has set each one's initial
    /// state; returns the run folders in the order of `cases`. Each case is an independent run
    /// (its own world, seed and folder), so the results do not depend on the number of threads.
    /// The first failed case (in the order of `cases`) is the error.
    pub fn sub_runs(
        &self,
        cases: &[(String, Config)],
        prepare: impl Fn(usize, &mut World) + Sync,
    ) -> Result<Vec<PathBuf>, ExperimentError> {
        use rayon::prelude::*;
        let done = std::sync::atomic::AtomicUsize::new(0);
        let results: Vec<Result<PathBuf, ExperimentError>> = self.pool.install(|| {
            cases
                .par_iter()
                .enumerate()
                .map(|(i, (name, config))| {
                    // After a signal no case starts (exit code 130).
                    crate::interrupt::check(|| format!("before case {name}")).map_err(RunError::Sim)?;
                    let start = std::time::Instant::now();
                    let result = self.sub_run(name, config, |w| prepare(i, w));
                    let n = done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
                    if self.progress {
                        eprintln!(
                            "experiment {}: case {name} {} in {:.1} s ({n} of {} done)",
                            self.name,
                            if result.is_ok() { "finished" } else { "FAILED" },
                            start.elapsed().as_secs_f64(),
                            cases.len()
                        );
                    }
                    result
                })
                .collect()
        });
        results.into_iter().collect()
    }

    /// Runs `config` as a sub-run named `name` inside the experiment folder, after `prepare` has
    /// changed the initial state (e.g. set a launch velocity). Returns the run folder.
    pub fn sub_run(
        &self,
        name: &str,
        config: &Config,
        prepare: impl FnOnce(&mut World),
    ) -> Result<PathBuf, ExperimentError> {
        let mut config = config.clone();
        force_analysis_recording(&mut config);
        config.general.output_dir = self.folder.display().to_string();
        config.general.run_name = name.to_string();
        config.validate().map_err(|e| RunError::Sim(e.into()))?;
        let options = RunOptions { config_source: format!("experiment {name}"), ..RunOptions::default() };
        let mut world = run::build_world(&config, &options).map_err(RunError::from)?;
        prepare(&mut world);
        world.forward();
        let sim = Simulation::new(&config, world);
        let summary = run::run_simulation(&config, &options, sim)?;
        // The quantities the thesis plotted (head motion, contacts, forces, penetration, joint
        // angles, torques, paths), next to the data.
        crate::plot::plot_run_folder(&summary.run_folder).map_err(|e| match e {
            crate::plot::PlotError::Interrupted { .. } => ExperimentError::Run(RunError::Plot(e)),
            e => ExperimentError::Data(format!("plots of {}: {e}", summary.run_folder.display())),
        })?;
        Ok(summary.run_folder)
    }
}

/// The outcome of an experiment.
#[derive(Debug)]
pub struct Outcome {
    /// The experiment folder (with `report.md`).
    pub folder: PathBuf,
    /// The report.
    pub report: Report,
    /// What the experiment changed in the base config's recording settings (also in the report).
    pub notes: Vec<String>,
    /// Wall time of the whole experiment (s); not in the report, which stays reproducible.
    pub wall_secs: f64,
    /// Threads the cases ran on.
    pub threads: usize,
}

/// Sets the recording settings every experiment's analysis needs, whatever the base config says:
/// recording on, CSV tables (Parquet-only becomes CSV and Parquet) and every table switch on.
/// Returns one note per setting changed.
pub fn force_analysis_recording(config: &mut Config) -> Vec<String> {
    use crate::config::TableFormat;
    let r = &mut config.recording;
    let mut notes = Vec::new();
    if !r.enabled {
        r.enabled = true;
        notes.push("recording.enabled = false -> true".to_string());
    }
    if !r.format.csv() {
        r.format = TableFormat::Both;
        notes.push("recording.format = \"parquet\" -> \"both\" (the analysis reads the CSV tables)".to_string());
    }
    let switches: [(&str, &mut bool); 16] = [
        ("link_position", &mut r.link_position),
        ("link_orientation", &mut r.link_orientation),
        ("link_velocity", &mut r.link_velocity),
        ("link_acceleration", &mut r.link_acceleration),
        ("link_angular_velocity", &mut r.link_angular_velocity),
        ("link_angular_acceleration", &mut r.link_angular_acceleration),
        ("joint_angles", &mut r.joint_angles),
        ("joint_velocities", &mut r.joint_velocities),
        ("torque_actuator_forces", &mut r.torque_actuator_forces),
        ("position_actuator_forces", &mut r.position_actuator_forces),
        ("velocity_actuator_forces", &mut r.velocity_actuator_forces),
        ("intvelocity_actuator_forces", &mut r.intvelocity_actuator_forces),
        ("external_contact_forces", &mut r.external_contact_forces),
        ("internal_joint_forces", &mut r.internal_joint_forces),
        ("imu_sensors", &mut r.imu_sensors),
        ("contacts", &mut r.contacts),
    ];
    for (name, on) in switches {
        if !*on {
            *on = true;
            notes.push(format!("recording.{name} = false -> true"));
        }
    }
    notes
}

/// Runs experiment `name` on top of `base` (the user's config: keys the experiment does not set
/// keep their values) and writes its report; cases in parallel on all cores, no progress lines.
pub fn run_experiment(name: &str, base: &Config, output_dir: &Path, quick: bool) -> Result<Outcome, ExperimentError> {
    run_experiment_with(name, base, output_dir, &ExperimentOptions { quick, ..ExperimentOptions::default() })
}

/// [`run_experiment`] with the number of threads and progress lines chosen. The report's
/// introduction gives the wall time and the threads.
pub fn run_experiment_with(
    name: &str,
    base: &Config,
    output_dir: &Path,
    options: &ExperimentOptions,
) -> Result<Outcome, ExperimentError> {
    if !NAMES.contains(&name) {
        return Err(ExperimentError::Unknown(name.to_string()));
    }
    if let Some(message) = crate::threads_beyond_cap("threads", options.threads) {
        return Err(ExperimentError::Data(message));
    }
    if name != "estimation" && (options.seeds.is_some() || options.floor.is_some()) {
        return Err(ExperimentError::Option(format!(
            "--seeds and --floor choose the peg-field runs of the `estimation` experiment; `{name}` takes neither"
        )));
    }
    if let Some(floor) = options.floor
        && !matches!(floor, crate::config::GroundModel::Isotropic | crate::config::GroundModel::Anisotropic)
    {
        return Err(ExperimentError::Option(format!(
            "--floor {floor:?}: the estimation experiment runs on an isotropic or an anisotropic floor"
        )));
    }
    if options.seeds.as_ref().is_some_and(Vec::is_empty) {
        return Err(ExperimentError::Option("--seeds: no seeds given".into()));
    }
    if name != "oal-bench" && options.oal.is_some() {
        return Err(ExperimentError::Option(format!(
            "the benchmark options (fields, families, floors, duration, conditions, shard, merge) are `oal-bench`'s; \
             `{name}` takes none of them"
        )));
    }
    if let Some(o) = &options.oal {
        o.bench.check()?;
    }
    if let Some(seeds) = options.seeds.as_ref().filter(|s| s.len() > MAX_SEEDS) {
        return Err(ExperimentError::Option(format!(
            "--seeds: {} seeds; give at most {MAX_SEEDS} (each is a peg-field run per floor)",
            seeds.len()
        )));
    }
    let start = std::time::Instant::now();
    let quick = options.quick;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .build()
        .map_err(|e| ExperimentError::Data(format!("cannot start {} worker threads: {e}", options.threads)))?;
    let threads = pool.current_num_threads();
    let unix_secs =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let folder = match &options.folder {
        Some(f) => {
            std::fs::create_dir_all(f)
                .map_err(|e| RunError::from(record::RecordError::Io { path: f.clone(), source: e }))?;
            f.clone()
        }
        None => record::create_run_folder(output_dir, &format!("experiment-{name}"), &record::utc_stamp(unix_secs))
            .map_err(RunError::from)?,
    };
    let ctx = Context {
        folder: folder.clone(),
        quick,
        name: name.to_string(),
        pool,
        progress: options.progress,
        seeds: options.seeds.clone(),
        floor: options.floor,
        oal: options.oal.clone(),
    };
    // Every case records what its analysis reads (Context::sub_run forces it); say what changed.
    let notes: Vec<String> = force_analysis_recording(&mut base.clone())
        .into_iter()
        .map(|n| format!("{n}: the experiment's analysis reads the recorded tables"))
        .collect();
    // Only `configure` knows where the original tool's capsules go; the other experiments' cases
    // (positions, launch directions, expected values) are laid out for SimSerpent's links.
    let mut notes = notes;
    let mut own_base;
    let base = if name != "configure" && base.legacy.geometry == crate::config::LegacyGeometry::Faithful {
        own_base = base.clone();
        own_base.legacy.geometry = crate::config::LegacyGeometry::NoOverlap;
        notes.push(format!(
            "legacy.geometry = \"faithful\" -> \"no_overlap\": the cases of `{name}` are laid out for SimSerpent's \
             links (only `configure` places the original tool's capsules)"
        ));
        &own_base
    } else {
        base
    };
    // The thesis' experiments study open-loop gaits: the configured gait drives the joints even
    // when the config selects another controller (the default job's path following).
    let mut gait_base = base.clone();
    gait_base.control.controller = crate::config::ControllerKind::Gait;
    let base = &gait_base;
    let mut report = Report { title: format!("SimSerpent experiment `{name}`"), ..Report::default() };
    let cases = match name {
        "estimation" => "Each case below wrote estimation_<case>.csv and plots/ next to this report.",
        "oal-bench" => {
            "The runs are in memory: oal_runs.csv, oal_summary.csv, oal_paired.csv, oal_heading.csv, oal_bare.csv \
             and plots/ next to this report."
        }
        _ => "Each case below is a run folder next to this report (config.toml, model.xml, tables).",
    };
    report.intro = format!(
        "SimSerpent {}, MuJoCo {}. {cases} Quick mode: {quick}.",
        env!("CARGO_PKG_VERSION"),
        crate::sim::engine_version()
    );
    if !notes.is_empty() {
        report.intro.push_str(&format!(" Settings forced for every case: {}.", notes.join("; ")));
    }
    let section = match name {
        "collision" => collision::run(&ctx, base),
        "undulation" => locomotion::undulation(&ctx, base),
        "oal" => locomotion::oal(&ctx, base),
        "form-closure" => locomotion::form_closure(&ctx, base),
        "estimation" => estimation::run(&ctx, base),
        "bounce" => bounce::run(&ctx, base),
        "oal-bench" => oal_bench::run(&ctx, base),
        _ => locomotion::configure(&ctx, base),
    };
    // The shards of one oal-bench share a folder: each its own report, the merge report.md.
    let path = match options.oal.as_ref().and_then(|o| if o.merge { None } else { o.bench.shard }) {
        Some((i, n)) => folder.join(format!("report-shard-{i}-of-{n}.md")),
        None => folder.join("report.md"),
    };
    let section = match section {
        Err(e) if e.interrupted() => {
            // What ran stays: the finished cases' folders, the stopped ones marked `incomplete`;
            // the report says the experiment is incomplete and checks nothing.
            report.intro.push_str(&format!(
                "\n\n**Incomplete**: {e}. The case folders written so far are kept (a stopped case's manifest says \
                 `incomplete`); no check was evaluated. Run the experiment again for a report."
            ));
            let _ = std::fs::write(&path, report.to_markdown());
            return Err(e);
        }
        other => other?,
    };
    report.sections.push(section);
    std::fs::write(&path, report.to_markdown())
        .map_err(|e| RunError::from(record::RecordError::Io { path: path.clone(), source: e }))?;
    Ok(Outcome { folder, report, notes, wall_secs: start.elapsed().as_secs_f64(), threads })
}

//! The thesis' experiments (chapter 7) and more, as commands with physics checks.
//!
//! `simserpent experiment <name>` creates `runs/experiment-<name>-<UTC time>/` holding one run
//! folder per case (data and plots, PNG and SVG) and `report.md`: what was run,
//! with which contact settings, a table of the measured numbers and every physics check with its
//! measured value, expected value, tolerance and pass/fail. The command exits 0 when every check
//! passes and 1 otherwise.

mod collision;
mod data;
pub mod estimation;
mod locomotion;
mod report;

pub use data::Table;
pub use locomotion::averaged_viscous_speed;
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
    /// No such experiment.
    #[error("unknown experiment `{0}`; available: {list}", list = NAMES.join(", "))]
    Unknown(String),
}

/// The experiments, by command name.
pub const NAMES: [&str; 6] = ["configure", "collision", "undulation", "form-closure", "oal", "estimation"];

/// Where an experiment writes and how long its runs are.
pub struct Context {
    /// The experiment folder.
    pub folder: PathBuf,
    /// Shorter runs (for tests): fewer gait cycles, same checks.
    pub quick: bool,
}

impl Context {
    /// Runs `config` as a sub-run named `name` inside the experiment folder, after `prepare` has
    /// changed the initial state (e.g. set a launch velocity). Returns the run folder.
    pub fn sub_run(
        &self,
        name: &str,
        config: &Config,
        prepare: impl FnOnce(&mut World),
    ) -> Result<PathBuf, ExperimentError> {
        let mut config = config.clone();
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
        crate::plot::plot_run_folder(&summary.run_folder)
            .map_err(|e| ExperimentError::Data(format!("plots of {}: {e}", summary.run_folder.display())))?;
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
}

/// Runs experiment `name` on top of `base` (the user's config: keys the experiment does not set
/// keep their values) and writes its report.
pub fn run_experiment(name: &str, base: &Config, output_dir: &Path, quick: bool) -> Result<Outcome, ExperimentError> {
    if !NAMES.contains(&name) {
        return Err(ExperimentError::Unknown(name.to_string()));
    }
    let unix_secs =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let folder = record::create_run_folder(output_dir, &format!("experiment-{name}"), &record::utc_stamp(unix_secs))
        .map_err(RunError::from)?;
    let ctx = Context { folder: folder.clone(), quick };
    // The thesis' experiments study open-loop gaits: the configured gait drives the joints even
    // when the config selects another controller (the default job's path following).
    let mut gait_base = base.clone();
    gait_base.control.controller = crate::config::ControllerKind::Gait;
    let base = &gait_base;
    let mut report = Report { title: format!("SimSerpent experiment `{name}`"), ..Report::default() };
    let cases = match name {
        "estimation" => "Each case below wrote estimation_<case>.csv and plots/ next to this report.",
        _ => "Each case below is a run folder next to this report (config.toml, model.xml, tables).",
    };
    report.intro = format!(
        "SimSerpent {}, MuJoCo {}. {cases} Quick mode: {quick}.",
        env!("CARGO_PKG_VERSION"),
        crate::sim::engine_version()
    );
    let section = match name {
        "collision" => collision::run(&ctx, base)?,
        "undulation" => locomotion::undulation(&ctx, base)?,
        "oal" => locomotion::oal(&ctx, base)?,
        "form-closure" => locomotion::form_closure(&ctx, base)?,
        "estimation" => estimation::run(&ctx, base)?,
        _ => locomotion::configure(&ctx, base)?,
    };
    report.sections.push(section);
    let path = folder.join("report.md");
    std::fs::write(&path, report.to_markdown())
        .map_err(|e| RunError::from(record::RecordError::Io { path: path.clone(), source: e }))?;
    Ok(Outcome { folder, report })
}

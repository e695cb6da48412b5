//! Parameter sweeps: many runs of one base config with some keys varied, in parallel.
//!
//! - **Variations** (`--vary key.path=SPEC`, [`spec`]): `SPEC` is a list of TOML values
//!   `5,10,15` (also strings: `torque,position`), a grid range `lo:hi:step` (inclusive) or, for
//!   sampling, a range `lo:hi`. Integer bounds give integers.
//! - **Plans** ([`plan`](mod@plan)): the full grid (the first `--vary` varies slowest), or
//!   `samples` random or Latin hypercube samples from a seeded ChaCha8 stream (lists are
//!   sampled by index).
//! - **Runs** ([`exec`]): each run is the base config plus one `--set` per varied key; its id
//!   (and folder name under `<sweep dir>/runs/`) is derived from the parameter values and the
//!   resolved base config, never from the time, so the same sweep gives the same folders. Runs
//!   go in parallel on a rayon pool; every run builds its own model and engine state inside its
//!   task.
//! - **Restarts**: a run whose folder holds a `manifest.json` with status `complete` is skipped
//!   (its summary is read back); failed, interrupted and missing runs are (re)done. After
//!   SIGINT/SIGTERM ([`crate::interrupt`]) running runs stop cleanly, no new run starts, and the
//!   summary marks them `incomplete`.
//! - **Summary** ([`summary`]): `summary.csv` (and `summary.parquet` with the `parquet`
//!   feature), one row per run: index, id, parameters, status, error, folder and the run's
//!   [`METRICS`]; every column has its type from the start. With `--shard i/n` only runs with
//!   `index % n == i` run and the summary is `summary-shard-i-of-n.csv`; [`merge_shards`]
//!   ([`merge`]) joins the shard summaries into `summary.csv`.

pub mod exec;
pub mod merge;
pub mod plan;
pub mod spec;
pub mod summary;

pub use exec::{RunOutcome, SkippedSummary, SweepReport, SweepRow, prepare, run_planned, run_sweep};
pub use merge::merge_shards;
pub use plan::{PlannedRun, default_sweep_dir, plan};
pub use spec::{SampleMode, Shard, SweepSpec, Values, Variation};
pub use summary::{Cell, CellValue, Column, ColumnType, METRICS, Metric, SummaryTable, write_summary};

use crate::config::ConfigError;
use std::path::{Path, PathBuf};

/// Errors of setting up or summarising a sweep (a failing *run* is not an error: it is
/// recorded in the summary and the sweep goes on).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SweepError {
    /// The base config, or a varied key, is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A `--vary`, `--sample` or `--shard` argument that cannot be used.
    #[error("{argument}: {message}")]
    Argument {
        /// The argument as written.
        argument: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// A file or folder of the sweep could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A summary file to read is empty.
    #[error("{path}: empty file")]
    EmptyFile {
        /// The file.
        path: PathBuf,
    },
    /// A file read as a summary is not one (first column not `run_index`, rows of different
    /// lengths, or a cell that is not of its column's type).
    #[error("{path}: not a sweep summary")]
    NotASummary {
        /// The file.
        path: PathBuf,
    },
    /// `sweep-merge` found no shard summaries.
    #[error("{folder}: no summary-shard-*.csv files to merge")]
    NoShards {
        /// The sweep folder.
        folder: PathBuf,
    },
    /// Shard summaries of different sweeps.
    #[error("{path}: columns differ from {first}: not the same sweep")]
    ShardsDiffer {
        /// The shard summary whose columns differ.
        path: PathBuf,
        /// The first shard summary.
        first: PathBuf,
    },
    /// A file of the sweep folder that is not one SimSerpent reads or writes ([`crate::files`]).
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// Another sweep is writing into the same folder.
    #[error(
        "{folder}: another sweep ({what}) is running in this folder; wait for it to finish or use another --sweep-dir"
    )]
    Locked {
        /// The sweep folder.
        folder: PathBuf,
        /// The other sweep: "the whole sweep", "shard 1/4".
        what: String,
    },
    /// `sweep-merge` found shards that do not make up the planned sweep (`sweep.json`).
    #[error("{folder}: {problem}")]
    ShardsIncomplete {
        /// The sweep folder.
        folder: PathBuf,
        /// Missing shards, a run twice, a run the plan does not hold.
        problem: String,
    },
    /// The thread pool could not be built.
    #[error("cannot start {threads} worker threads: {source}")]
    Threads {
        /// Requested pool size.
        threads: usize,
        /// Rayon's error.
        #[source]
        source: rayon::ThreadPoolBuildError,
    },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> SweepError + '_ {
    move |source| SweepError::Io { path: path.to_path_buf(), source }
}

fn argument(argument: &str, message: impl Into<String>) -> SweepError {
    SweepError::Argument { argument: argument.to_string(), message: message.into() }
}

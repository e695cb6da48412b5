//! Parameter sweeps: many runs of one base config with some keys varied, in parallel.
//!
//! - **Variations** (`--vary key.path=SPEC`): `SPEC` is a list of TOML values `5,10,15` (also
//!   strings: `torque,position`), a grid range `lo:hi:step` (inclusive) or, for sampling, a
//!   range `lo:hi`. Integer bounds give integers.
//! - **Plans**: the full grid (the first `--vary` varies slowest), or `samples` random or Latin
//!   hypercube samples from a seeded ChaCha8 stream (lists are sampled by index).
//! - **Runs**: each run is the base config plus one `--set` per varied key; its id (and folder
//!   name under `<sweep dir>/runs/`) is derived from the parameter values and the resolved base
//!   config, never from the time, so the same sweep gives the same folders. Runs go in parallel
//!   on a rayon pool; every run builds its own model and engine state inside its task.
//! - **Restarts**: a run whose folder holds a `manifest.json` with status `complete` is skipped
//!   (its summary is read back); failed, interrupted and missing runs are (re)done. After
//!   SIGINT/SIGTERM ([`crate::interrupt`]) running runs stop cleanly, no new run starts, and the
//!   summary marks them `incomplete`.
//! - **Summary**: `summary.csv` (and `summary.parquet` with the `parquet` feature), one row per
//!   run: index, id, parameters, status, error, folder and the run's metrics. With
//!   `--shard i/n` only runs with `index % n == i` run and the summary is
//!   `summary-shard-i-of-n.csv`; [`merge_shards`] joins the shard summaries into `summary.csv`.

use crate::config::{self, Config, ConfigError, ConfigSource};
use crate::run::{self, RunOptions, RunSummary};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;
use toml::Value;

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
    /// A file of the sweep folder could not be read or written.
    #[error("{path}: {message}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The OS or format error.
        message: String,
    },
    /// The thread pool could not be built.
    #[error("cannot start {threads} worker threads: {message}")]
    Threads {
        /// Requested pool size.
        threads: usize,
        /// Rayon's message.
        message: String,
    },
}

impl SweepError {
    /// 2 for bad input (config or arguments), 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Config(_) | Self::Argument { .. } => 2,
            _ => 1,
        }
    }
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> SweepError + '_ {
    move |e| SweepError::Io { path: path.to_path_buf(), message: e.to_string() }
}

fn argument(argument: &str, message: impl Into<String>) -> SweepError {
    SweepError::Argument { argument: argument.to_string(), message: message.into() }
}

/// The values one key takes.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// Explicit values (TOML literals).
    List(Vec<Value>),
    /// `lo:hi` or `lo:hi:step`; `integer` when both bounds were written as integers.
    Range {
        /// Lower bound.
        lo: f64,
        /// Upper bound (inclusive).
        hi: f64,
        /// Grid step (needed for grids).
        step: Option<f64>,
        /// Integer values only.
        integer: bool,
    },
}

/// One `--vary key.path=SPEC`.
#[derive(Debug, Clone, PartialEq)]
pub struct Variation {
    /// Dotted config key, as in the config file.
    pub key: String,
    /// Its values.
    pub values: Values,
}

fn parse_value(text: &str) -> Value {
    // As `--set`: a TOML literal, or a bare word taken as a string.
    config::parse_override(&format!("x={text}")).map(|(_, v)| v).unwrap_or_else(|_| Value::String(text.to_string()))
}

fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

impl Variation {
    /// Parses `key.path=5,10,15`, `key.path=0.5:2.0:0.5` or `key.path=0.5:2.0`.
    ///
    /// # Errors
    /// [`SweepError::Argument`] naming the argument.
    pub fn parse(arg: &str) -> Result<Self, SweepError> {
        let Some((key, spec)) = arg.split_once('=') else {
            return Err(argument(arg, "expected `key.path=v1,v2,...`, `key.path=lo:hi:step` or `key.path=lo:hi`"));
        };
        let (key, spec) = (key.trim(), spec.trim());
        // The key syntax is that of `--set`.
        config::parse_override(&format!("{key}=0")).map_err(|e| argument(arg, e.to_string()))?;
        if spec.is_empty() {
            return Err(argument(arg, "no values after `=`"));
        }
        let is_range = spec.contains(':') && !spec.starts_with(['"', '\'', '[', '{']);
        if is_range {
            let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
            if !(2..=3).contains(&parts.len()) {
                return Err(argument(arg, "a range is `lo:hi` or `lo:hi:step`"));
            }
            let values: Vec<Value> = parts.iter().map(|p| parse_value(p)).collect();
            let nums: Option<Vec<f64>> = values.iter().map(number).collect();
            let Some(nums) = nums.filter(|n| n.iter().all(|x| x.is_finite())) else {
                return Err(argument(arg, "range bounds and step must be finite numbers"));
            };
            let (lo, hi) = (nums[0], nums[1]);
            if hi < lo {
                return Err(argument(arg, format!("range {lo}:{hi} has its upper bound below its lower bound")));
            }
            let step = nums.get(2).copied();
            if step.is_some_and(|s| s <= 0.0) {
                return Err(argument(arg, "the step of a range must be > 0"));
            }
            let integer = values[..2].iter().all(|v| matches!(v, Value::Integer(_)))
                && values.get(2).is_none_or(|v| matches!(v, Value::Integer(_)));
            return Ok(Self { key: key.to_string(), values: Values::Range { lo, hi, step, integer } });
        }
        let values: Vec<Value> = split_list(spec).iter().map(|p| parse_value(p)).collect();
        Ok(Self { key: key.to_string(), values: Values::List(values) })
    }

    /// The grid values.
    fn grid(&self) -> Result<Vec<Value>, SweepError> {
        match &self.values {
            Values::List(v) => Ok(v.clone()),
            Values::Range { lo, hi, step, integer } => {
                let Some(step) = step else {
                    return Err(argument(
                        &self.key,
                        "a grid needs a step (`lo:hi:step`); `lo:hi` ranges are for --sample random|lhs",
                    ));
                };
                let n = ((hi - lo) / step + 1e-9).floor() as u64 + 1;
                if n > 1_000_000 {
                    return Err(argument(&self.key, format!("{n} values; at most 1000000 per key")));
                }
                Ok((0..n).map(|i| make_value(lo + i as f64 * step, *integer)).collect())
            }
        }
    }

    /// The value at unit position `u` in [0, 1).
    fn sample(&self, u: f64) -> Value {
        match &self.values {
            Values::List(v) => v[((u * v.len() as f64) as usize).min(v.len().saturating_sub(1))].clone(),
            Values::Range { lo, hi, integer: true, .. } => {
                let x = (lo + u * (hi - lo + 1.0)).floor().min(*hi);
                make_value(x, true)
            }
            Values::Range { lo, hi, .. } => make_value(lo + u * (hi - lo), false),
        }
    }
}

/// Splits `a,b,[1,2],"x,y"` at the commas that are outside brackets and quotes.
fn split_list(spec: &str) -> Vec<String> {
    let (mut out, mut current, mut depth, mut quote) = (Vec::new(), String::new(), 0i32, None::<char>);
    for c in spec.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (None, '"' | '\'') => quote = Some(c),
            (None, '[' | '{') => depth += 1,
            (None, ']' | '}') => depth -= 1,
            (None, ',') if depth == 0 => {
                out.push(current.trim().to_string());
                current.clear();
                continue;
            }
            _ => {}
        }
        current.push(c);
    }
    out.push(current.trim().to_string());
    out.retain(|s| !s.is_empty());
    out
}

fn make_value(x: f64, integer: bool) -> Value {
    if integer {
        Value::Integer(x.round() as i64)
    } else {
        // Remove the float noise of lo + i*step (0.30000000000000004).
        let rounded = (x * 1e12).round() / 1e12;
        Value::Float(if rounded.is_finite() { rounded } else { x })
    }
}

/// How the parameter sets are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleMode {
    /// Every combination.
    Grid,
    /// Independent uniform samples.
    Random,
    /// Latin hypercube: each key's range cut into `samples` strata, each stratum used once.
    LatinHypercube,
}

impl std::str::FromStr for SampleMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "grid" => Ok(Self::Grid),
            "random" => Ok(Self::Random),
            "lhs" => Ok(Self::LatinHypercube),
            other => Err(format!("unknown sample mode `{other}`; allowed: grid, random, lhs")),
        }
    }
}

/// `--shard i/n`: this process runs the runs with `index % n == i` (0 <= i < n).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard (0-based).
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let err = || format!("`{s}`: expected `i/n` with 0 <= i < n, e.g. `0/4` (Slurm: $SLURM_ARRAY_TASK_ID/N)");
        let (i, n) = s.split_once('/').ok_or_else(err)?;
        let (index, count): (usize, usize) =
            (i.trim().parse().map_err(|_| err())?, n.trim().parse().map_err(|_| err())?);
        if count == 0 || index >= count {
            return Err(err());
        }
        Ok(Self { index, count })
    }
}

/// A whole sweep.
#[derive(Debug, Clone)]
pub struct SweepSpec {
    /// Base config file (`None`: the embedded default).
    pub config_path: Option<PathBuf>,
    /// `--set` overrides applied to the base before the variations.
    pub overrides: Vec<String>,
    /// The varied keys.
    pub variations: Vec<Variation>,
    /// Grid or sampling.
    pub mode: SampleMode,
    /// Number of samples (random, lhs).
    pub samples: usize,
    /// Seed of the sampling stream.
    pub seed: u64,
    /// The sweep folder (`None`: `<general.output_dir>/sweep-<name>`).
    pub sweep_dir: Option<PathBuf>,
    /// Worker threads (0: all cores).
    pub threads: usize,
    /// Only this shard.
    pub shard: Option<Shard>,
    /// Show a progress bar (only on a terminal).
    pub progress: bool,
}

/// One planned run.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedRun {
    /// Position in the full plan (stable for the same arguments).
    pub index: usize,
    /// Stable id: the run folder's name.
    pub id: String,
    /// (key, value) per varied key, in `--vary` order.
    pub params: Vec<(String, Value)>,
}

/// What happened to a run.
#[derive(Debug, Clone, PartialEq)]
pub enum RunOutcome {
    /// Ran now and completed.
    Complete(RunSummary),
    /// Completed in an earlier invocation; the summary was read from its manifest.
    Skipped(SkippedSummary),
    /// Failed (also: invalid parameter combination); the message says why.
    Failed(String),
    /// Stopped by SIGINT/SIGTERM ([`crate::interrupt`]), or not started because of one; redone
    /// by the next invocation.
    Interrupted(String),
}

/// The metrics of a run finished earlier, read back from its `manifest.json`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SkippedSummary {
    /// `metric name -> value` as in [`RunSummary`].
    pub metrics: Vec<(String, f64)>,
    /// Wall time of that run (s).
    pub wall_secs: f64,
}

/// One row of the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// The plan entry.
    pub run: PlannedRun,
    /// Its outcome.
    pub outcome: RunOutcome,
    /// Its folder.
    pub folder: PathBuf,
    /// Wall seconds this invocation spent on it (0 for skipped).
    pub wall_secs: f64,
}

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

/// FNV-1a, 64 bit: a hash that is the same on every machine and Rust version.
fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// `key=value` as a `--set` argument (TOML literal).
fn set_arg(key: &str, value: &Value) -> String {
    format!("{key}={value}")
}

/// A value for folder names and summaries: strings without quotes.
fn plain(value: &Value) -> String {
    match value {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

fn run_id(params: &[(String, Value)], base_fingerprint: u64) -> String {
    let mut canonical: Vec<String> = params.iter().map(|(k, v)| set_arg(k, v)).collect();
    canonical.sort();
    let hash = fnv1a(&format!("{base_fingerprint:016x}\n{}", canonical.join("\n")));
    let mut slug = String::new();
    for (key, value) in params {
        let short = key.rsplit('.').next().unwrap_or(key);
        let _ = write!(slug, "{short}-{}_", plain(value));
    }
    let mut slug: String =
        slug.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '.' | '_') { c } else { '_' }).collect();
    if slug.len() > 80 {
        slug.truncate(80);
        slug.push('_');
    }
    // FNV's high bits barely change between similar texts: mix them (MurmurHash3's finaliser).
    let mut h = hash;
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^= h >> 33;
    format!("{slug}{h:016x}")
}

fn load_base(spec: &SweepSpec, extra: &[String]) -> Result<Config, ConfigError> {
    let overrides: Vec<String> = spec.overrides.iter().chain(extra).cloned().collect();
    match &spec.config_path {
        Some(path) => config::load_config(path, &overrides),
        None => config::load_config_str(config::DEFAULT_CONFIG_TOML, ConfigSource::Toml, &overrides),
    }
}

/// The full, deterministic list of runs of a sweep, plus the resolved base config.
///
/// # Errors
/// A base config or `--vary` key that is invalid (a misspelt key fails here, before anything
/// runs; a value that is invalid only for some runs fails those runs).
pub fn plan(spec: &SweepSpec) -> Result<(Config, Vec<PlannedRun>), SweepError> {
    let base = load_base(spec, &[])?;
    if spec.variations.is_empty() {
        return Err(argument("--vary", "give at least one `--vary key.path=values`"));
    }
    for v in &spec.variations {
        if spec.variations.iter().filter(|w| w.key == v.key).count() > 1 {
            return Err(argument(&v.key, "varied twice"));
        }
        if let Values::List(list) = &v.values
            && list.is_empty()
        {
            return Err(argument(&v.key, "no values"));
        }
        // The key must exist (unknown keys fail with a did-you-mean); a value that is merely
        // out of range for this base is left to the runs.
        let probe = match &v.values {
            Values::List(list) => list[0].clone(),
            Values::Range { lo, integer, .. } => make_value(*lo, *integer),
        };
        if let Err(e) = load_base(spec, &[set_arg(&v.key, &probe)])
            && !matches!(e, ConfigError::InvalidValue { .. })
        {
            return Err(e.into());
        }
    }
    let fingerprint = fnv1a(&base.to_toml_string());
    // Integer keys (n_links, counts) get integers, float keys floats, whatever the bounds say.
    let base_table: toml::Table = base.to_toml_string().parse().unwrap_or_default();
    let mut variations = spec.variations.clone();
    for v in &mut variations {
        let mut current: Option<&Value> = None;
        for segment in v.key.split('.') {
            current = match current {
                None => base_table.get(segment),
                Some(Value::Table(t)) => t.get(segment),
                Some(_) => None,
            };
        }
        if let (Values::Range { integer, .. }, Some(value)) = (&mut v.values, current) {
            match value {
                Value::Integer(_) => *integer = true,
                Value::Float(_) => *integer = false,
                _ => {}
            }
        }
    }
    let spec = &SweepSpec { variations, ..spec.clone() };
    let keys: Vec<&str> = spec.variations.iter().map(|v| v.key.as_str()).collect();
    let sets: Vec<Vec<Value>> = match spec.mode {
        SampleMode::Grid => {
            let axes = spec.variations.iter().map(Variation::grid).collect::<Result<Vec<_>, _>>()?;
            let total = axes.iter().try_fold(1usize, |acc, a| acc.checked_mul(a.len()));
            match total {
                Some(n) if n <= 1_000_000 => {}
                _ => return Err(argument("--vary", "the grid has more than 1000000 runs")),
            }
            let mut sets = vec![Vec::new()];
            for axis in &axes {
                sets = sets
                    .into_iter()
                    .flat_map(|prefix| {
                        axis.iter().map(move |v| {
                            let mut s = prefix.clone();
                            s.push(v.clone());
                            s
                        })
                    })
                    .collect();
            }
            sets
        }
        SampleMode::Random | SampleMode::LatinHypercube => {
            let n = spec.samples;
            if n == 0 || n > 1_000_000 {
                return Err(argument("--samples", "give 1 to 1000000 samples with --sample random|lhs"));
            }
            let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
            let mut units = vec![vec![0.0; spec.variations.len()]; n];
            if spec.mode == SampleMode::Random {
                for row in &mut units {
                    for u in row.iter_mut() {
                        *u = rng.random::<f64>();
                    }
                }
            } else {
                for k in 0..spec.variations.len() {
                    let mut strata: Vec<usize> = (0..n).collect();
                    for i in (1..n).rev() {
                        strata.swap(i, rng.random_range(0..=i));
                    }
                    for (row, stratum) in units.iter_mut().zip(strata) {
                        row[k] = (stratum as f64 + rng.random::<f64>()) / n as f64;
                    }
                }
            }
            units.iter().map(|row| spec.variations.iter().zip(row).map(|(v, u)| v.sample(*u)).collect()).collect()
        }
    };
    let mut runs = Vec::with_capacity(sets.len());
    let mut seen = std::collections::HashSet::new();
    for values in sets {
        let params: Vec<(String, Value)> = keys.iter().map(|k| k.to_string()).zip(values).collect();
        let id = run_id(&params, fingerprint);
        // Equal parameter sets (e.g. integer samples) are one run.
        if seen.insert(id.clone()) {
            runs.push(PlannedRun { index: runs.len(), id, params });
        }
    }
    Ok((base, runs))
}

/// The default sweep folder: `<general.output_dir>/sweep-<config file stem or "default">`.
pub fn default_sweep_dir(spec: &SweepSpec, base: &Config) -> PathBuf {
    let stem = spec
        .config_path
        .as_ref()
        .and_then(|p| p.file_stem())
        .map_or("default".to_string(), |s| s.to_string_lossy().into_owned());
    Path::new(&base.general.output_dir).join(format!("sweep-{stem}"))
}

/// Whether `folder/manifest.json` says the run completed; then its metrics.
fn finished(folder: &Path) -> Option<SkippedSummary> {
    let text = std::fs::read_to_string(folder.join("manifest.json")).ok()?;
    let manifest: serde_json::Value = serde_json::from_str(&text).ok()?;
    if manifest.get("status")?.as_str()? != "complete" {
        return None;
    }
    let summary = manifest.get("summary")?;
    let metrics = METRICS
        .iter()
        .map(|name| (name.to_string(), summary.get(name).and_then(serde_json::Value::as_f64).unwrap_or(f64::NAN)))
        .collect();
    let wall_secs = manifest.get("wall_time_secs").and_then(serde_json::Value::as_f64).unwrap_or(f64::NAN);
    Some(SkippedSummary { metrics, wall_secs })
}

/// The metrics of a run in the summary, in column order (names as in [`RunSummary`]).
pub const METRICS: [&str; 9] = [
    "simulated_secs",
    "distance_m",
    "mean_speed_m_per_s",
    "forward_speed_m_per_s",
    "heading_deg",
    "peak_contact_force_n",
    "max_penetration_m",
    "actuator_energy_j",
    "steps_per_wall_sec",
];

fn metric_values(summary: &RunSummary) -> [f64; 9] {
    [
        summary.simulated_secs,
        summary.distance_m,
        summary.mean_speed_m_per_s,
        summary.forward_speed_m_per_s,
        summary.heading_deg,
        summary.peak_contact_force_n,
        summary.max_penetration_m,
        summary.actuator_energy_j,
        summary.steps_per_wall_sec,
    ]
}

fn run_one(spec: &SweepSpec, run: &PlannedRun, folder: &Path, command_line: &[String]) -> RunOutcome {
    if let Some(done) = finished(folder) {
        return RunOutcome::Skipped(done);
    }
    if crate::interrupt::requested() {
        return RunOutcome::Interrupted("not started: the sweep was interrupted".into());
    }
    let mut extra: Vec<String> = run.params.iter().map(|(k, v)| set_arg(k, v)).collect();
    extra.push(set_arg("general.run_name", &Value::String(run.id.clone())));
    let config = match load_base(spec, &extra) {
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
        Err(e @ run::RunError::Interrupted { .. }) => RunOutcome::Interrupted(e.to_string()),
        Err(e) => RunOutcome::Failed(e.to_string()),
    }
}

/// Runs a sweep (or one shard of it) and writes its summary.
///
/// # Errors
/// Bad arguments or base config; the sweep folder or summary cannot be written. Failing runs
/// are not errors.
pub fn run_sweep(spec: &SweepSpec) -> Result<SweepReport, SweepError> {
    let (sweep_dir, runs) = prepare(spec)?;
    let mine: Vec<&PlannedRun> = match spec.shard {
        Some(s) => runs.iter().filter(|r| r.index % s.count == s.index).collect(),
        None => runs.iter().collect(),
    };
    let mut builder = rayon::ThreadPoolBuilder::new();
    if spec.threads > 0 {
        builder = builder.num_threads(spec.threads);
    }
    let pool = builder.build().map_err(|e| SweepError::Threads { threads: spec.threads, message: e.to_string() })?;
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
    let summary_csv = write_summary(spec, &sweep_dir, &table)?;
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
    let runs_dir = sweep_dir.join("runs");
    std::fs::create_dir_all(&runs_dir).map_err(io_error(&runs_dir))?;
    write_plan(spec, &sweep_dir, &runs)?;
    Ok((sweep_dir, runs))
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

/// Writes `summary.csv` (and `summary.parquet` with the `parquet` feature), or
/// `summary-shard-i-of-n.*` for a shard, into `sweep_dir`; returns the CSV's path.
///
/// # Errors
/// [`SweepError::Io`].
pub fn write_summary(spec: &SweepSpec, sweep_dir: &Path, table: &SummaryTable) -> Result<PathBuf, SweepError> {
    let name = match spec.shard {
        Some(s) => format!("summary-shard-{}-of-{}", s.index, s.count),
        None => "summary".to_string(),
    };
    let summary_csv = sweep_dir.join(format!("{name}.csv"));
    table.write_csv(&summary_csv)?;
    #[cfg(feature = "parquet")]
    table.write_parquet(&sweep_dir.join(format!("{name}.parquet")))?;
    Ok(summary_csv)
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

/// `sweep.json`: what the sweep is (arguments and every planned run), for people and for merges.
fn write_plan(spec: &SweepSpec, sweep_dir: &Path, runs: &[PlannedRun]) -> Result<(), SweepError> {
    let plan = serde_json::json!({
        "simserpent_version": env!("CARGO_PKG_VERSION"),
        "config": spec.config_path.as_ref().map(|p| p.display().to_string()),
        "overrides": spec.overrides,
        "vary": spec.variations.iter().map(|v| v.key.clone()).collect::<Vec<_>>(),
        "mode": format!("{:?}", spec.mode),
        "samples": spec.samples,
        "seed": spec.seed,
        "runs": runs.iter().map(|r| serde_json::json!({
            "index": r.index,
            "id": r.id,
            "params": r.params.iter().map(|(k, v)| (k.clone(), serde_json::Value::String(plain(v))))
                .collect::<serde_json::Map<_, _>>(),
        })).collect::<Vec<_>>(),
    });
    let path = sweep_dir.join("sweep.json");
    let text = serde_json::to_string_pretty(&plan)
        .map_err(|e| SweepError::Io { path: path.clone(), message: e.to_string() })?;
    std::fs::write(&path, text + "\n").map_err(io_error(&path))
}

/// The summary as text cells (what the CSV holds), with a column kind for Parquet.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryTable {
    /// Column names.
    pub header: Vec<String>,
    /// Rows of cells (`""` for a missing metric).
    pub rows: Vec<Vec<String>>,
}

fn fmt_f64(x: f64) -> String {
    if x.is_finite() { ryu::Buffer::new().format_finite(x).to_string() } else { String::new() }
}

impl SummaryTable {
    /// The summary of `rows` (columns: index, id, the varied keys, status, error, folder,
    /// [`METRICS`], `wall_secs`).
    pub fn from_rows(variations: &[Variation], rows: &[SweepRow]) -> Self {
        let mut header: Vec<String> = ["run_index", "run_id"].map(String::from).to_vec();
        header.extend(variations.iter().map(|v| v.key.clone()));
        header.extend(["status", "error", "run_folder"].map(String::from));
        header.extend(METRICS.iter().map(|m| m.to_string()));
        header.push("wall_secs".into());
        let rows = rows
            .iter()
            .map(|r| {
                let mut cells = vec![r.run.index.to_string(), r.run.id.clone()];
                cells.extend(r.run.params.iter().map(|(_, v)| plain(v)));
                let (status, error, metrics, wall) = match &r.outcome {
                    RunOutcome::Complete(s) => ("complete", String::new(), metric_values(s).to_vec(), r.wall_secs),
                    RunOutcome::Skipped(s) => {
                        ("complete", String::new(), s.metrics.iter().map(|(_, v)| *v).collect(), s.wall_secs)
                    }
                    RunOutcome::Failed(e) => ("failed", e.clone(), vec![f64::NAN; METRICS.len()], r.wall_secs),
                    RunOutcome::Interrupted(e) => ("incomplete", e.clone(), vec![f64::NAN; METRICS.len()], r.wall_secs),
                };
                cells.push(status.into());
                cells.push(error);
                cells.push(format!("runs/{}", r.run.id));
                cells.extend(metrics.iter().map(|x| fmt_f64(*x)));
                cells.push(fmt_f64(wall));
                cells
            })
            .collect();
        Self { header, rows }
    }

    /// Writes the CSV (RFC 4180 quoting for cells with commas, quotes or newlines).
    ///
    /// # Errors
    /// [`SweepError::Io`].
    pub fn write_csv(&self, path: &Path) -> Result<(), SweepError> {
        let mut text = String::new();
        for row in std::iter::once(&self.header).chain(&self.rows) {
            let cells: Vec<String> = row.iter().map(|c| quote(c)).collect();
            text.push_str(&cells.join(","));
            text.push('\n');
        }
        std::fs::write(path, text).map_err(io_error(path))
    }

    /// Reads a CSV written by [`SummaryTable::write_csv`].
    ///
    /// # Errors
    /// [`SweepError::Io`] when the file cannot be read or is not a summary.
    pub fn read_csv(path: &Path) -> Result<Self, SweepError> {
        let text = std::fs::read_to_string(path).map_err(io_error(path))?;
        let mut records = parse_csv(&text).into_iter();
        let header =
            records.next().ok_or_else(|| SweepError::Io { path: path.to_path_buf(), message: "empty file".into() })?;
        let rows: Vec<Vec<String>> = records.collect();
        if header.first().map(String::as_str) != Some("run_index") || rows.iter().any(|r| r.len() != header.len()) {
            return Err(SweepError::Io { path: path.to_path_buf(), message: "not a sweep summary".into() });
        }
        Ok(Self { header, rows })
    }

    /// Writes the Parquet twin: `run_index` int64; numeric columns float64 (missing: NaN); text
    /// columns (and parameters that are not all numbers) UTF-8.
    ///
    /// # Errors
    /// [`SweepError::Io`].
    #[cfg(feature = "parquet")]
    pub fn write_parquet(&self, path: &Path) -> Result<(), SweepError> {
        use crate::record::{ColumnKind, ParquetTable, TableSink};
        let err = |e: std::io::Error| SweepError::Io { path: path.to_path_buf(), message: e.to_string() };
        let text_columns = ["run_id", "status", "error", "run_folder"];
        let metric_columns: Vec<&str> = METRICS.iter().copied().chain(["wall_secs"]).collect();
        let kinds: Vec<ColumnKind> = self
            .header
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let all_ints = !self.rows.is_empty() && self.rows.iter().all(|r| r[i].parse::<u64>().is_ok());
                if name == "run_index" || (all_ints && !metric_columns.contains(&name.as_str())) {
                    ColumnKind::Int
                } else if text_columns.contains(&name.as_str())
                    || !self.rows.iter().all(|r| r[i].is_empty() || r[i].parse::<f64>().is_ok())
                {
                    ColumnKind::Text
                } else {
                    ColumnKind::Float
                }
            })
            .collect();
        let mut table =
            ParquetTable::create(path, &self.header, &kinds, 10_000, crate::config::ParquetCompression::Zstd)
                .map_err(err)?;
        for row in &self.rows {
            for (cell, kind) in row.iter().zip(&kinds) {
                match kind {
                    ColumnKind::Int => table.int(cell.parse().unwrap_or(0)),
                    ColumnKind::Float => table.num(cell.parse().unwrap_or(f64::NAN)),
                    ColumnKind::Text => table.text(cell),
                }
                .map_err(err)?;
            }
            table.end_row().map_err(err)?;
        }
        table.finish().map_err(err)
    }
}

fn quote(cell: &str) -> String {
    if cell.contains([',', '"', '\n', '\r']) { format!("\"{}\"", cell.replace('"', "\"\"")) } else { cell.to_string() }
}

fn parse_csv(text: &str) -> Vec<Vec<String>> {
    let (mut records, mut record, mut field) = (Vec::new(), Vec::new(), String::new());
    let (mut in_quotes, mut chars) = (false, text.chars().peekable());
    while let Some(c) = chars.next() {
        match (in_quotes, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            (true, '"') => in_quotes = false,
            (true, c) => field.push(c),
            (false, '"') => in_quotes = true,
            (false, ',') => record.push(std::mem::take(&mut field)),
            (false, '\r') => {}
            (false, '\n') => {
                record.push(std::mem::take(&mut field));
                records.push(std::mem::take(&mut record));
            }
            (false, c) => field.push(c),
        }
    }
    if !field.is_empty() || !record.is_empty() {
        record.push(field);
        records.push(record);
    }
    records
}

/// Joins the shard summaries `summary-shard-*-of-N.csv` of `sweep_dir` into `summary.csv` (and
/// `summary.parquet`), ordered by run index. Returns the merged table and the files it read.
///
/// # Errors
/// No shard summaries, summaries of different sweeps (headers differ), or I/O.
pub fn merge_shards(sweep_dir: &Path) -> Result<(SummaryTable, Vec<PathBuf>), SweepError> {
    let entries = std::fs::read_dir(sweep_dir).map_err(io_error(sweep_dir))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("summary-shard-") && n.ends_with(".csv"))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(SweepError::Io {
            path: sweep_dir.to_path_buf(),
            message: "no summary-shard-*.csv files to merge".into(),
        });
    }
    let mut merged: Option<SummaryTable> = None;
    for file in &files {
        let table = SummaryTable::read_csv(file)?;
        match merged.as_mut() {
            None => merged = Some(table),
            Some(m) => {
                if m.header != table.header {
                    return Err(SweepError::Io {
                        path: file.clone(),
                        message: format!("columns differ from {}: not the same sweep", files[0].display()),
                    });
                }
                m.rows.extend(table.rows);
            }
        }
    }
    let mut merged = merged.unwrap_or(SummaryTable { header: Vec::new(), rows: Vec::new() });
    merged.rows.sort_by_key(|r| r.first().and_then(|i| i.parse::<u64>().ok()).unwrap_or(u64::MAX));
    merged.rows.dedup_by(|a, b| a.first() == b.first());
    merged.write_csv(&sweep_dir.join("summary.csv"))?;
    #[cfg(feature = "parquet")]
    merged.write_parquet(&sweep_dir.join("summary.parquet"))?;
    Ok((merged, files))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_lists_and_ranges() {
        let v = Variation::parse("snake.n_links=5,10,15").expect("list");
        assert_eq!(v.values, Values::List(vec![Value::Integer(5), Value::Integer(10), Value::Integer(15)]));
        let v = Variation::parse("gait.sine_wave.frequency_hz=0.5:2.0:0.5").expect("range");
        let grid = v.grid().expect("grid");
        assert_eq!(grid, [0.5, 1.0, 1.5, 2.0].map(Value::Float).to_vec());
        let v = Variation::parse("general.timestep_secs=0.1:0.3:0.1").expect("range");
        assert_eq!(v.grid().expect("grid"), [0.1, 0.2, 0.3].map(Value::Float).to_vec());
        let v = Variation::parse("control.method=torque,position").expect("words");
        assert_eq!(v.values, Values::List(vec![Value::String("torque".into()), Value::String("position".into())]));
        let v = Variation::parse("snake.torque_range_nm=[-1.0, 1.0],[-2.0, 2.0]").expect("arrays");
        assert!(matches!(&v.values, Values::List(l) if l.len() == 2));
        assert!(Variation::parse("snake.n_links").is_err());
        assert!(Variation::parse("snake.n_links=5:1").is_err());
        assert!(Variation::parse("snake.n_links=1:5:0").is_err());
        assert!(Variation::parse("snake.n_links=1:5").expect("range").grid().is_err());
    }

    #[test]
    fn integer_ranges_sample_integers_within_bounds() {
        let v = Variation::parse("snake.n_links=3:6").expect("range");
        for u in [0.0, 0.24, 0.25, 0.5, 0.99999] {
            let Value::Integer(i) = v.sample(u) else { panic!("not an integer") };
            assert!((3..=6).contains(&i));
        }
        assert_eq!(v.sample(0.0), Value::Integer(3));
        assert_eq!(v.sample(0.99), Value::Integer(6));
    }

    #[test]
    fn shard_syntax() {
        assert_eq!("1/4".parse::<Shard>(), Ok(Shard { index: 1, count: 4 }));
        assert!("4/4".parse::<Shard>().is_err());
        assert!("0/0".parse::<Shard>().is_err());
        assert!("x".parse::<Shard>().is_err());
    }

    #[test]
    fn csv_quoting_round_trips() {
        let cells = ["plain", "a,b", "say \"hi\"", "line\nbreak", ""];
        let line: Vec<String> = cells.iter().map(|c| quote(c)).collect();
        let parsed = parse_csv(&(line.join(",") + "\n"));
        assert_eq!(parsed, vec![cells.map(String::from).to_vec()]);
    }

    #[test]
    fn fnv_is_stable() {
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
    }
}

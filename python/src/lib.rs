//! `simserpent._core`: the PyO3 binding of the SimSerpent library.
//!
//! Thin on purpose: configs go through the library's own loading pipeline
//! (`simserpent::config`), environments are `simserpent::env::EnvCore`, runs are
//! `simserpent::run::run` and sweep runs `simserpent::sweep::run_planned`. Long calls (runs,
//! vector steps, sweeps) release the GIL (`Python::detach`). Errors become `SimSerpentError`
//! subclasses whose message is the CLI's (`config <source>: <error>` for config errors).

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rayon::prelude::*;
use simserpent::config::{self, Config, ConfigError as LibConfigError, ConfigSource};
use simserpent::env::{EnvCore, StepOutcome};
use simserpent::run::{RunError, RunOptions, RunSummary};
use simserpent::sim::SimError;
use simserpent::sweep::{self, SampleMode, SummaryTable, SweepError as LibSweepError, SweepSpec, Variation};
use std::path::PathBuf;

create_exception!(_core, SimSerpentError, PyException, "Any SimSerpent error; the message is the CLI's.");
create_exception!(_core, ConfigError, SimSerpentError, "A bad config: names the key, the value and what is allowed.");
create_exception!(_core, ModelError, SimSerpentError, "MuJoCo rejected a model, or a robot file cannot be used.");
create_exception!(_core, SimulationError, SimSerpentError, "The simulation diverged.");
create_exception!(_core, RecordError, SimSerpentError, "The run folder or a table could not be written.");
create_exception!(_core, SweepError, SimSerpentError, "Bad sweep arguments, or the sweep folder could not be written.");

/// The error and its causes, `: `-separated, leaving out a cause the text already contains
/// (what the CLI prints after `error: `).
fn error_text(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut cause = error.source();
    while let Some(c) = cause {
        let s = c.to_string();
        if !text.contains(&s) {
            text.push_str(": ");
            text.push_str(&s);
        }
        cause = c.source();
    }
    text
}

fn config_err(source: &str, e: &LibConfigError) -> PyErr {
    ConfigError::new_err(format!("config {source}: {}", error_text(e)))
}

fn sim_err(source: &str, e: &SimError) -> PyErr {
    match e {
        SimError::Config(c) => config_err(source, c),
        SimError::Diverged { .. } => SimulationError::new_err(error_text(e)),
        _ => ModelError::new_err(error_text(e)),
    }
}

fn run_err(source: &str, e: &RunError) -> PyErr {
    match e {
        RunError::Sim(s) => sim_err(source, s),
        RunError::Record(_) => RecordError::new_err(error_text(e)),
        _ => SimSerpentError::new_err(error_text(e)),
    }
}

fn sweep_err(e: &LibSweepError) -> PyErr {
    match e {
        LibSweepError::Config(c) => ConfigError::new_err(error_text(c)),
        _ => SweepError::new_err(error_text(e)),
    }
}

/// A resolved, validated configuration.
#[pyclass(name = "Config", module = "simserpent._core", frozen)]
#[derive(Clone)]
struct PyConfig {
    inner: Config,
    /// Where it came from (a path, `<dict>`, `embedded default`), as the CLI names it.
    source: String,
}

#[pymethods]
impl PyConfig {
    /// The resolved config as TOML (what a run folder's `config.toml` holds).
    fn to_toml(&self) -> String {
        self.inner.to_toml_string()
    }

    /// The resolved config as a JSON string (`json.loads` gives nested dicts).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner).map_err(|e| SimSerpentError::new_err(e.to_string()))
    }

    /// Where the config came from.
    #[getter]
    fn source(&self) -> String {
        self.source.clone()
    }

    /// A copy with `key.path=value` overrides applied (as the CLI's `--set`).
    fn with_overrides(&self, overrides: Vec<String>) -> PyResult<PyConfig> {
        let text = self.inner.to_toml_string();
        let inner =
            config::load_config_str(&text, ConfigSource::Toml, &overrides).map_err(|e| config_err(&self.source, &e))?;
        Ok(PyConfig { inner, source: self.source.clone() })
    }

    /// The MJCF the config generates.
    fn mjcf(&self) -> PyResult<String> {
        simserpent::model::generate(&self.inner).map(|g| g.xml).map_err(|e| sim_err(&self.source, &SimError::from(e)))
    }

    /// The MJCF an environment of this config runs (`control.method` taken from `env.action`).
    fn env_mjcf(&self) -> PyResult<String> {
        let c = simserpent::env::env_model_config(&self.inner);
        simserpent::model::generate(&c).map(|g| g.xml).map_err(|e| sim_err(&self.source, &SimError::from(e)))
    }

    fn __repr__(&self) -> String {
        format!("simserpent.Config(source={:?})", self.source)
    }
}

/// `load_config(path=None, json=None, overrides=[])`: from a file (`.toml` or the original
/// tool's `.json`), from a JSON text of a dict (what Python's dicts become), or the embedded
/// default; then the overrides.
#[pyfunction]
#[pyo3(signature = (path=None, json=None, overrides=Vec::new()))]
fn load_config(path: Option<PathBuf>, json: Option<String>, overrides: Vec<String>) -> PyResult<PyConfig> {
    match (path, json) {
        (Some(_), Some(_)) => Err(ConfigError::new_err("give a config file or a dict, not both")),
        (Some(path), None) => {
            let source = path.display().to_string();
            let inner = config::load_config(&path, &overrides).map_err(|e| config_err(&source, &e))?;
            Ok(PyConfig { inner, source })
        }
        (None, Some(json)) => {
            let source = "<dict>".to_string();
            let value: serde_json::Value =
                serde_json::from_str(&json).map_err(|e| ConfigError::new_err(format!("config {source}: {e}")))?;
            let table: toml::Table = toml::Table::try_from(value)
                .map_err(|e| ConfigError::new_err(format!("config {source}: not a TOML table: {e}")))?;
            let text = toml::to_string(&table)
                .map_err(|e| ConfigError::new_err(format!("config {source}: cannot convert to TOML: {e}")))?;
            let inner =
                config::load_config_str(&text, ConfigSource::Toml, &overrides).map_err(|e| config_err(&source, &e))?;
            Ok(PyConfig { inner, source })
        }
        (None, None) => {
            let source = "embedded default".to_string();
            let inner = config::load_config_str(config::DEFAULT_CONFIG_TOML, ConfigSource::Toml, &overrides)
                .map_err(|e| config_err(&source, &e))?;
            Ok(PyConfig { inner, source })
        }
    }
}

/// The embedded, commented default config (what `simserpent init` writes).
#[pyfunction]
fn default_config_toml() -> &'static str {
    config::DEFAULT_CONFIG_TOML
}

/// MuJoCo's version string, as the linked library reports it.
#[pyfunction]
fn mujoco_version() -> String {
    mujoco_rs::mujoco_version().to_string()
}

fn summary_dict<'py>(py: Python<'py>, s: &RunSummary) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("run_folder", s.run_folder.display().to_string())?;
    for metric in sweep::METRICS {
        d.set_item(metric.name, (metric.value)(s))?;
    }
    d.set_item("real_time_factor", s.real_time_factor)?;
    Ok(d)
}

/// Runs a whole configured simulation (the CLI's `simserpent run`) with the GIL released;
/// returns the summary (with `run_folder`).
#[pyfunction]
#[pyo3(signature = (config, run_folder=None))]
fn run<'py>(py: Python<'py>, config: &PyConfig, run_folder: Option<PathBuf>) -> PyResult<Bound<'py, PyDict>> {
    let options = RunOptions {
        config_source: config.source.clone(),
        command_line: vec!["python: simserpent.run".into()],
        run_folder,
        ..RunOptions::default()
    };
    let c = config.inner.clone();
    let result = py.detach(move || simserpent::run::run(&c, &options));
    match result {
        Ok(summary) => summary_dict(py, &summary),
        Err(e) => Err(run_err(&config.source, &e)),
    }
}

fn step_info<'py>(py: Python<'py>, out: &StepOutcome, time_secs: f64) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("forward_progress_m", out.terms.forward_progress_m)?;
    d.set_item("energy_j", out.terms.energy_j)?;
    d.set_item("peak_contact_force_n", out.terms.peak_contact_force_n)?;
    d.set_item("time_secs", time_secs)?;
    if let Some(e) = &out.error {
        d.set_item("error", e)?;
    }
    Ok(d)
}

/// One environment (the core of `simserpent.SimSerpentEnv`).
#[pyclass(module = "simserpent._core")]
struct Env {
    core: EnvCore,
    obs: Vec<f64>,
    /// The action, copied out of the numpy array so the step can run without the GIL.
    action: Vec<f64>,
    source: String,
}

#[pymethods]
impl Env {
    #[new]
    fn new(config: &PyConfig) -> PyResult<Self> {
        let core = EnvCore::new(&config.inner).map_err(|e| sim_err(&config.source, &e))?;
        let obs = vec![0.0; core.observation_size()];
        let action = vec![0.0; core.action_size()];
        Ok(Self { core, obs, action, source: config.source.clone() })
    }

    /// Starts an episode; returns the first observation.
    fn reset<'py>(&mut self, py: Python<'py>, seed: u64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.core.reset(seed, &mut self.obs).map_err(|e| sim_err(&self.source, &e))?;
        Ok(PyArray1::from_slice(py, &self.obs))
    }

    /// Holds `action` for one control period: (observation, reward, terminated, truncated, info).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, f64, bool, bool, Bound<'py, PyDict>)> {
        let action = action.as_slice()?;
        if action.len() != self.core.action_size() {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "action has {} values; this snake has {} joints",
                action.len(),
                self.core.action_size()
            )));
        }
        self.action.copy_from_slice(action);
        // The physics runs without the GIL: other Python threads (e.g. one env per thread) go on.
        let Self { core, obs, action, .. } = self;
        let out = py.detach(|| core.step(action, obs));
        let info = step_info(py, &out, self.core.time_secs())?;
        Ok((PyArray1::from_slice(py, &self.obs), out.reward, out.terminated, out.truncated, info))
    }

    #[getter]
    fn observation_size(&self) -> usize {
        self.core.observation_size()
    }
    #[getter]
    fn observation_names(&self) -> Vec<String> {
        self.core.observation_names()
    }
    #[getter]
    fn observation_version(&self) -> u32 {
        self.core.config().env.observation_version
    }
    #[getter]
    fn action_size(&self) -> usize {
        self.core.action_size()
    }
    #[getter]
    fn action_low<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.action_bounds().0)
    }
    #[getter]
    fn action_high<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.action_bounds().1)
    }
    #[getter]
    fn action_kind(&self) -> &'static str {
        match self.core.config().env.action {
            config::EnvAction::Position => "position",
            config::EnvAction::Torque => "torque",
        }
    }
    #[getter]
    fn substeps(&self) -> u64 {
        self.core.substeps()
    }
    #[getter]
    fn timestep_secs(&self) -> f64 {
        self.core.config().general.timestep_secs
    }
    #[getter]
    fn control_period_secs(&self) -> f64 {
        self.core.config().env.control_period_secs
    }
    #[getter]
    fn max_episode_steps(&self) -> u64 {
        self.core.max_episode_steps()
    }
    #[getter]
    fn time_secs(&self) -> f64 {
        self.core.time_secs()
    }
    #[getter]
    fn mjcf(&self) -> String {
        self.core.mjcf().to_string()
    }
    /// Centre of mass of the links (m).
    #[getter]
    fn centre_of_mass(&self) -> [f64; 3] {
        self.core.centre_of_mass()
    }
}

/// One environment's slice of the vector environment's buffers, as the step loop sees it.
type Slot<'a> = (
    (
        (
            (
                (
                    (((((&'a mut EnvCore, &'a mut [f64]), &'a [f64]), &'a mut f64), &'a mut [f64]), &'a mut bool),
                    &'a mut bool,
                ),
                &'a mut Option<String>,
            ),
            &'a mut bool,
        ),
        &'a mut u64,
    ),
    &'a u64,
);

/// Many environments stepped together in Rust on a rayon pool, with the GIL released
/// (the core of `simserpent.SimSerpentVectorEnv`). Automatic reset on the next step after an
/// episode ends (Gymnasium's `NEXT_STEP` mode).
#[pyclass(module = "simserpent._core")]
struct VecEnv {
    envs: Vec<EnvCore>,
    pool: rayon::ThreadPool,
    obs: Vec<f64>,
    rewards: Vec<f64>,
    terms: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    errors: Vec<Option<String>>,
    needs_reset: Vec<bool>,
    seeds: Vec<u64>,
    episodes: Vec<u64>,
    actions: Vec<f64>,
    source: String,
}

#[pymethods]
impl VecEnv {
    /// `num_envs` copies of the environment of `config`, stepped on `threads` threads (0: all
    /// cores).
    #[new]
    #[pyo3(signature = (config, num_envs, threads=0))]
    fn new(py: Python<'_>, config: &PyConfig, num_envs: usize, threads: usize) -> PyResult<Self> {
        if num_envs == 0 {
            return Err(pyo3::exceptions::PyValueError::new_err("num_envs must be at least 1"));
        }
        let c = config.inner.clone();
        let envs: Result<Vec<EnvCore>, SimError> =
            py.detach(move || (0..num_envs).into_par_iter().map(|_| EnvCore::new(&c)).collect());
        let envs = envs.map_err(|e| sim_err(&config.source, &e))?;
        let mut builder = rayon::ThreadPoolBuilder::new();
        if threads > 0 {
            builder = builder.num_threads(threads);
        }
        let pool = builder.build().map_err(|e| SimSerpentError::new_err(format!("cannot start threads: {e}")))?;
        let (n, no) = (num_envs, envs[0].observation_size());
        Ok(Self {
            pool,
            obs: vec![0.0; n * no],
            rewards: vec![0.0; n],
            terms: vec![0.0; n * 3],
            terminated: vec![false; n],
            truncated: vec![false; n],
            errors: vec![None; n],
            needs_reset: vec![false; n],
            seeds: (0..n as u64).collect(),
            episodes: vec![0; n],
            actions: vec![0.0; n * envs[0].action_size()],
            envs,
            source: config.source.clone(),
        })
    }

    /// Resets every environment: environment i gets seed `seed + i`; later automatic resets
    /// of it get `seed + i + k * num_envs` for its k-th episode. Returns the observations.
    fn reset<'py>(&mut self, py: Python<'py>, seed: u64) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.envs.len();
        let no = self.obs.len() / n;
        for i in 0..n {
            self.seeds[i] = seed.wrapping_add(i as u64);
            self.episodes[i] = 0;
            self.needs_reset[i] = false;
        }
        let (envs, obs, seeds, pool) = (&mut self.envs, &mut self.obs, &self.seeds, &self.pool);
        let result: Result<(), SimError> = py.detach(|| {
            pool.install(|| {
                envs.par_iter_mut()
                    .zip(obs.par_chunks_mut(no))
                    .zip(seeds.par_iter())
                    .try_for_each(|((env, o), s)| env.reset(*s, o))
            })
        });
        result.map_err(|e| sim_err(&self.source, &e))?;
        PyArray1::from_slice(py, &self.obs).reshape([n, no])
    }

    /// Steps every environment with its row of `actions` (num_envs x action_size):
    /// (observations, rewards, terminated, truncated, reward terms (num_envs x 3: progress,
    /// energy, peak force), errors). An environment whose episode ended at the previous step
    /// is reset instead (its row: the new first observation, reward 0, not done).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyList>,
    )> {
        let n = self.envs.len();
        let na = self.envs[0].action_size();
        let no = self.obs.len() / n;
        let shape = actions.shape();
        if shape != [n, na] {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "actions have shape {shape:?}; expected ({n}, {na})"
            )));
        }
        match actions.as_slice() {
            Ok(s) => self.actions.copy_from_slice(s),
            Err(_) => {
                let a = actions.as_array();
                for (dst, src) in self.actions.iter_mut().zip(a.iter()) {
                    *dst = *src;
                }
            }
        }
        let nenv = n as u64;
        let sequential = self.pool.current_num_threads() == 1;
        let Self {
            envs,
            pool,
            obs,
            rewards,
            terms,
            terminated,
            truncated,
            errors,
            needs_reset,
            seeds,
            episodes,
            actions,
            ..
        } = self;
        let one = |((((((((((env, o), a), r), t), term), trunc), err), reset), episode), seed): Slot<'_>| {
            if *reset {
                *episode += 1;
                let s = seed.wrapping_add(*episode * nenv);
                *err = env.reset(s, o).err().map(|e| e.to_string());
                *r = 0.0;
                t.fill(0.0);
                *term = err.is_some();
                *trunc = false;
                *reset = *term;
                return;
            }
            let out = env.step(a, o);
            *r = out.reward;
            t[0] = out.terms.forward_progress_m;
            t[1] = out.terms.energy_j;
            t[2] = out.terms.peak_contact_force_n;
            *term = out.terminated;
            *trunc = out.truncated;
            *reset = out.terminated || out.truncated;
            *err = out.error;
        };
        py.detach(|| {
            if sequential {
                // One thread: step in this thread, no hand-over to the pool.
                envs.iter_mut()
                    .zip(obs.chunks_mut(no))
                    .zip(actions.chunks(na))
                    .zip(rewards.iter_mut())
                    .zip(terms.chunks_mut(3))
                    .zip(terminated.iter_mut())
                    .zip(truncated.iter_mut())
                    .zip(errors.iter_mut())
                    .zip(needs_reset.iter_mut())
                    .zip(episodes.iter_mut())
                    .zip(seeds.iter())
                    .for_each(one);
            } else {
                // One rayon task per environment: an idle thread takes over the environments of
                // a thread that the OS preempted (the step waits for the slowest thread).
                pool.install(|| {
                    envs.par_iter_mut()
                        .with_max_len(1)
                        .zip(obs.par_chunks_mut(no))
                        .zip(actions.par_chunks(na))
                        .zip(rewards.par_iter_mut())
                        .zip(terms.par_chunks_mut(3))
                        .zip(terminated.par_iter_mut())
                        .zip(truncated.par_iter_mut())
                        .zip(errors.par_iter_mut())
                        .zip(needs_reset.par_iter_mut())
                        .zip(episodes.par_iter_mut())
                        .zip(seeds.par_iter())
                        .for_each(one);
                })
            }
        });
        let errors = PyList::new(py, self.errors.iter().cloned())?;
        Ok((
            PyArray1::from_slice(py, &self.obs).reshape([n, no])?,
            PyArray1::from_slice(py, &self.rewards),
            PyArray1::from_slice(py, &self.terminated),
            PyArray1::from_slice(py, &self.truncated),
            PyArray1::from_slice(py, &self.terms).reshape([n, 3])?,
            errors,
        ))
    }

    #[getter]
    fn num_envs(&self) -> usize {
        self.envs.len()
    }
    #[getter]
    fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }
    #[getter]
    fn observation_size(&self) -> usize {
        self.obs.len() / self.envs.len()
    }
    #[getter]
    fn action_size(&self) -> usize {
        self.envs[0].action_size()
    }
    #[getter]
    fn action_low<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.envs[0].action_bounds().0)
    }
    #[getter]
    fn action_high<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.envs[0].action_bounds().1)
    }
    #[getter]
    fn max_episode_steps(&self) -> u64 {
        self.envs[0].max_episode_steps()
    }
}

fn sweep_spec(
    config_path: Option<PathBuf>,
    overrides: Vec<String>,
    vary: &[String],
    sample: &str,
    samples: usize,
    seed: u64,
    sweep_dir: Option<PathBuf>,
) -> PyResult<SweepSpec> {
    let variations: Vec<Variation> =
        vary.iter().map(|v| Variation::parse(v)).collect::<Result<_, _>>().map_err(|e| sweep_err(&e))?;
    let mode: SampleMode =
        sample.parse().map_err(|e: String| SweepError::new_err(format!("--sample {sample}: {e}")))?;
    Ok(SweepSpec {
        config_path,
        overrides,
        variations,
        mode,
        samples,
        seed,
        sweep_dir,
        threads: 1,
        shard: None,
        progress: false,
    })
}

/// A planned run for Python: (index, id, [(key, value as written)]).
type PlannedRunRow = (usize, String, Vec<(String, String)>);

/// A sweep, planned once by the driver and run run-by-run elsewhere (Ray tasks): the same
/// plan, run ids, run folders and summary table as `simserpent sweep`.
#[pyclass(module = "simserpent._core", frozen)]
struct Sweep {
    spec: SweepSpec,
    sweep_dir: PathBuf,
    runs: Vec<sweep::PlannedRun>,
}

#[pymethods]
impl Sweep {
    /// Plans the sweep (arguments as the CLI's `--vary`, `--sample`, `--samples`, `--seed`,
    /// `--set`, `--sweep-dir`); with `prepare` (the driver) creates the sweep folder and writes
    /// `sweep.json`, without it (a worker) only computes the same plan.
    #[new]
    #[pyo3(signature = (config_path=None, vary=Vec::new(), overrides=Vec::new(), sample="grid", samples=10, seed=0, sweep_dir=None, prepare=true))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        config_path: Option<PathBuf>,
        vary: Vec<String>,
        overrides: Vec<String>,
        sample: &str,
        samples: usize,
        seed: u64,
        sweep_dir: Option<PathBuf>,
        prepare: bool,
    ) -> PyResult<Self> {
        let spec = sweep_spec(config_path, overrides, &vary, sample, samples, seed, sweep_dir)?;
        let (sweep_dir, runs) = if prepare {
            sweep::prepare(&spec).map_err(|e| sweep_err(&e))?
        } else {
            let (base, runs) = sweep::plan(&spec).map_err(|e| sweep_err(&e))?;
            let dir = spec.sweep_dir.clone().unwrap_or_else(|| sweep::default_sweep_dir(&spec, &base));
            (dir, runs)
        };
        Ok(Self { spec, sweep_dir, runs })
    }

    #[getter]
    fn sweep_dir(&self) -> String {
        self.sweep_dir.display().to_string()
    }

    /// The planned runs: (index, id, {key: value as written}).
    fn runs(&self) -> Vec<PlannedRunRow> {
        self.runs
            .iter()
            .map(|r| (r.index, r.id.clone(), r.params.iter().map(|(k, v)| (k.clone(), v.to_string())).collect()))
            .collect()
    }

    /// The summary columns.
    fn header(&self) -> Vec<String> {
        SummaryTable::from_rows(&self.spec.variations, &[]).names()
    }

    /// Runs planned run `index` (GIL released) and returns its summary row (text cells).
    fn run_one(&self, py: Python<'_>, index: usize) -> PyResult<Vec<String>> {
        let run = self
            .runs
            .iter()
            .find(|r| r.index == index)
            .ok_or_else(|| SweepError::new_err(format!("no planned run with index {index}")))?
            .clone();
        let (spec, dir) = (&self.spec, &self.sweep_dir);
        let row = py.detach(|| sweep::run_planned(spec, &run, dir, &["python: simserpent.ray_sweep".to_string()]));
        let table = SummaryTable::from_rows(&spec.variations, std::slice::from_ref(&row));
        Ok(table.rows.first().map(|r| r.iter().map(|c| c.as_str().to_string()).collect()).unwrap_or_default())
    }

    /// Writes `summary.csv` (and `summary.parquet`) from rows returned by `run_one`, sorted by
    /// run index; returns the CSV's path.
    fn write_summary(&self, rows: Vec<Vec<String>>) -> PyResult<String> {
        let header = self.header();
        let mut rows = rows;
        if let Some(bad) = rows.iter().find(|r| r.len() != header.len()) {
            return Err(SweepError::new_err(format!("a row has {} cells; expected {}", bad.len(), header.len())));
        }
        rows.sort_by_key(|r| r.first().and_then(|c| c.parse::<usize>().ok()).unwrap_or(usize::MAX));
        let table = SummaryTable::from_text(header, rows)
            .ok_or_else(|| SweepError::new_err("the rows are not summary rows (a cell is not of its column's type)"))?;
        let path = sweep::write_summary(&self.spec, &self.sweep_dir, &table).map_err(|e| sweep_err(&e))?;
        Ok(path.display().to_string())
    }
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SimSerpentError", py.get_type::<SimSerpentError>())?;
    m.add("ConfigError", py.get_type::<ConfigError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("RecordError", py.get_type::<RecordError>())?;
    m.add("SweepError", py.get_type::<SweepError>())?;
    m.add_class::<PyConfig>()?;
    m.add_class::<Env>()?;
    m.add_class::<VecEnv>()?;
    m.add_class::<Sweep>()?;
    m.add_function(wrap_pyfunction!(load_config, m)?)?;
    m.add_function(wrap_pyfunction!(default_config_toml, m)?)?;
    m.add_function(wrap_pyfunction!(mujoco_version, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add("SWEEP_METRICS", sweep::METRICS.iter().map(|m| m.name).collect::<Vec<_>>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

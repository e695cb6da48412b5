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
use pyo3::types::{PyBytes, PyDict, PyList};
use rayon::prelude::*;
use simserpent::config::{self, Config, ConfigError as LibConfigError, ConfigSource};
use simserpent::control::{Command, Controller, JointTrajectory, Observation};
use simserpent::env::{EnvCore, EnvState, RewardTerms, StepOutcome};
use simserpent::estimate::{EstimateError as LibEstimateError, estimate_run_folder};
use simserpent::estimation::{ContactEstimates, MotionScore};
use simserpent::run::{ProgressCallback, RunError, RunOptions, RunSummary};
use simserpent::sim::SimError;
use simserpent::sweep::{self, SampleMode, SummaryTable, SweepError as LibSweepError, SweepSpec, Variation};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

create_exception!(_core, SimSerpentError, PyException, "Any SimSerpent error; the message is the CLI's.");
create_exception!(_core, ConfigError, SimSerpentError, "A bad config: names the key, the value and what is allowed.");
create_exception!(_core, ModelError, SimSerpentError, "MuJoCo rejected a model, or a robot file cannot be used.");
create_exception!(_core, SimulationError, SimSerpentError, "The simulation diverged.");
create_exception!(_core, RecordError, SimSerpentError, "The run folder or a table could not be written.");
create_exception!(_core, SweepError, SimSerpentError, "Bad sweep arguments, or the sweep folder could not be written.");
create_exception!(
    _core,
    RenderError,
    SimSerpentError,
    "Pictures or a video of a run folder cannot be made (no state.csv, no EGL, encoder failed)."
);
create_exception!(
    _core,
    PlotError,
    SimSerpentError,
    "A run folder cannot be plotted (missing table or column, a file cannot be written)."
);
create_exception!(
    _core,
    EstimateError,
    SimSerpentError,
    "A run folder cannot be estimated (missing file or column, unreadable table, plot failed)."
);

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

/// A seed argument: a Python integer (or numpy integer) from 0 to 2**64 - 1. The error names the
/// function, the argument, the value and what is allowed.
fn seed_arg(function: &str, value: &Bound<'_, PyAny>) -> PyResult<u64> {
    let allowed = "a whole number from 0 to 2**64 - 1 (18446744073709551615)";
    let shown = || value.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
    if value.is_instance_of::<pyo3::types::PyBool>() {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{function}: seed must be {allowed}, got the bool {}",
            shown()
        )));
    }
    if let Ok(seed) = value.extract::<u64>() {
        return Ok(seed);
    }
    if value.call_method0("__index__").is_ok() {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "{function}: seed must be {allowed}, got {}",
            shown()
        )));
    }
    let kind = value.get_type().name().map(|s| s.to_string()).unwrap_or_default();
    Err(pyo3::exceptions::PyTypeError::new_err(format!("{function}: seed must be {allowed}, got {kind} {}", shown())))
}

/// A value for an error message: its type and its (shortened) repr.
fn describe(value: &Bound<'_, PyAny>) -> String {
    let kind = value.get_type().name().map(|s| s.to_string()).unwrap_or_default();
    let shown: String = value.repr().map(|r| r.to_string()).unwrap_or_default().chars().take(80).collect();
    format!("{kind} {shown}")
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
        let c = simserpent::env::env_model_config(&self.inner).map_err(|e| config_err(&self.source, &e))?;
        simserpent::model::generate(&c).map(|g| g.xml).map_err(|e| sim_err(&self.source, &SimError::from(e)))
    }

    fn __repr__(&self) -> String {
        format!("simserpent.Config(source={:?})", self.source)
    }

    /// Pickling (deepcopy, spawn-context processes, Ray tasks): the resolved TOML and the
    /// source, rebuilt by `simserpent._core._config_from_toml`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String, String))> {
        let f = py.import("simserpent._core")?.getattr("_config_from_toml")?;
        Ok((f, (self.inner.to_toml_string(), self.source.clone())))
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.inner == other.inner
    }
}

/// A pickled config back (the TOML of a resolved config loads to the same config).
#[pyfunction]
fn _config_from_toml(toml_text: &str, source: String) -> PyResult<PyConfig> {
    let inner = config::load_config_str(toml_text, ConfigSource::Toml, &[]).map_err(|e| config_err(&source, &e))?;
    Ok(PyConfig { inner, source })
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

/// Contact estimates as a dict of numpy arrays (n = links): `active` (bool: an estimator filled
/// them), `external_force_n`, `floor_force_n`, `obstacle_force_n` (n × 3, N, world frame),
/// `contact` (n, bool), `contact_point_along_m` (n, m from the link's centre along its axis,
/// positive toward the head; NaN when unknown), `contact_point_m` (n × 3, world; NaN rows
/// when unknown), `self_contact_force_n` (n × 3, N: the other links' push) and `self_contact`
/// (n, bool: the link touches another link).
fn estimates_dict<'py>(py: Python<'py>, c: &ContactEstimates) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let rows = |v: &[[f64; 3]]| -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows: Vec<Vec<f64>> = v.iter().map(|r| r.to_vec()).collect();
        Ok(PyArray2::from_vec2(py, &rows)?)
    };
    d.set_item("active", c.active)?;
    d.set_item("external_force_n", rows(&c.external_force_n)?)?;
    d.set_item("floor_force_n", rows(&c.floor_force_n)?)?;
    d.set_item("obstacle_force_n", rows(&c.obstacle_force_n)?)?;
    d.set_item("contact", PyArray1::from_slice(py, &c.contact))?;
    let along: Vec<f64> = c.contact_point_along_m.iter().map(|p| p.unwrap_or(f64::NAN)).collect();
    d.set_item("contact_point_along_m", PyArray1::from_vec(py, along))?;
    let points: Vec<[f64; 3]> = c.contact_point_m.iter().map(|p| p.unwrap_or([f64::NAN; 3])).collect();
    d.set_item("contact_point_m", rows(&points)?)?;
    d.set_item("self_contact_force_n", rows(&c.self_contact_force_n)?)?;
    d.set_item("self_contact", PyArray1::from_slice(py, &c.self_contact))?;
    Ok(d)
}

/// A [`MotionScore`] as a dict: counts, rates and errors (NaN where undefined).
fn score_dict<'py>(py: Python<'py>, s: &MotionScore) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("hits", s.hits)?;
    d.set_item("misses", s.misses)?;
    d.set_item("false_alarms", s.false_alarms)?;
    d.set_item("correct_rejections", s.correct_rejections)?;
    d.set_item("detection_rate", s.detection_rate())?;
    d.set_item("false_alarm_rate", s.false_alarm_rate())?;
    d.set_item("relative_force_rmse", s.relative_force_rmse())?;
    d.set_item("truth_rms_n", s.truth_rms_n())?;
    d.set_item("points", s.points)?;
    d.set_item("points_within", s.points_within)?;
    d.set_item("points_missing", s.points_missing)?;
    d.set_item("point_within_rate", s.point_within_rate())?;
    d.set_item("mean_point_error_m", s.mean_point_error_m())?;
    d.set_item("threshold_n", s.threshold_n)?;
    d.set_item("point_min_lateral_n", s.point_min_lateral_n)?;
    d.set_item("point_tolerance_m", s.point_tolerance_m)?;
    d.set_item("free_link_steps", s.free_link_steps)?;
    d.set_item("false_forces", s.false_forces)?;
    d.set_item("false_force_rate", s.false_force_rate())?;
    d.set_item("false_force_max_n", s.false_force_max_n)?;
    d.set_item("false_force_rms_n", s.false_force_rms_n())?;
    d.set_item("false_force_threshold_n", s.false_force_threshold_n)?;
    Ok(d)
}

/// `simserpent estimate RUN_FOLDER` (with the GIL released): runs the contact estimator of the
/// run's config (with `overrides`, `--set` syntax) on the recorded run and writes
/// `RUN_FOLDER/estimation/` (estimates.csv, scores.csv, scores.md, plots). Returns `folder`,
/// `rows`, the file paths, `total` (all links) and `per_link` scores.
#[pyfunction]
#[pyo3(signature = (run_folder, overrides=Vec::new()))]
fn estimate<'py>(py: Python<'py>, run_folder: PathBuf, overrides: Vec<String>) -> PyResult<Bound<'py, PyDict>> {
    let outcome = py.detach(|| estimate_run_folder(&run_folder, &overrides)).map_err(|e| {
        let text = error_text(&e);
        match e {
            LibEstimateError::Config { .. } => ConfigError::new_err(text),
            _ => EstimateError::new_err(text),
        }
    })?;
    let d = PyDict::new(py);
    let folder = &outcome.folder;
    d.set_item("folder", folder.display().to_string())?;
    d.set_item("rows", outcome.rows)?;
    for (key, file) in [("estimates_csv", "estimates.csv"), ("scores_csv", "scores.csv"), ("scores_md", "scores.md")] {
        d.set_item(key, folder.join(file).display().to_string())?;
    }
    d.set_item("total", score_dict(py, &outcome.total)?)?;
    let per_link = PyList::empty(py);
    for s in &outcome.per_link {
        per_link.append(score_dict(py, s)?)?;
    }
    d.set_item("per_link", per_link)?;
    Ok(d)
}

/// A Python callable as the run's controller: called at every physics step with the measured
/// observation (a dict; with `[estimation] enabled` its `contacts` entry holds the contact
/// estimates, see `estimates_dict`), it returns the joint command of `control.method` (a sequence of one
/// value per joint) or a dict of command blocks (`position_rad`, `velocity_rad_per_s`,
/// `intvelocity_rad_per_s`, `torque_nm`). Its first exception is kept and stops the run (the
/// command becomes NaN, which MuJoCo rejects at once).
struct PyController {
    callable: Py<PyAny>,
    method: config::ControlMethod,
    error: Arc<Mutex<Option<PyErr>>>,
}

impl PyController {
    fn call(&self, py: Python<'_>, obs: &Observation, cmd: &mut Command) -> PyResult<()> {
        let d = PyDict::new(py);
        d.set_item("time_secs", obs.time_secs)?;
        d.set_item("joint_angle_rad", PyArray1::from_slice(py, &obs.joint_angle_rad))?;
        d.set_item("joint_velocity_rad_per_s", PyArray1::from_slice(py, &obs.joint_velocity_rad_per_s))?;
        d.set_item("actuator_torque_nm", PyArray1::from_slice(py, &obs.actuator_torque_nm))?;
        d.set_item("head_position_m", PyArray1::from_slice(py, &obs.head_position_m))?;
        d.set_item("head_quat", PyArray1::from_slice(py, &obs.head_quat))?;
        d.set_item("head_yaw_rad", simserpent::state::yaw_rad(obs.head_quat))?;
        d.set_item("head_velocity_m_per_s", PyArray1::from_slice(py, &obs.head_velocity_m_per_s))?;
        if obs.contacts.active {
            d.set_item("contacts", estimates_dict(py, &obs.contacts)?)?;
        }
        let out = self.callable.bind(py).call1((d,))?;
        let nj = obs.n_joints();
        let put = |name: &str, value: &Bound<'_, PyAny>, block: &mut Vec<f64>| -> PyResult<()> {
            let v: Vec<f64> = value.extract().map_err(|_| {
                pyo3::exceptions::PyTypeError::new_err(format!(
                    "the controller's {name} must be a sequence of {nj} numbers (one per joint)"
                ))
            })?;
            if v.len() != nj {
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "the controller returned {} values for {name}; this snake has {nj} joints",
                    v.len()
                )));
            }
            block.copy_from_slice(&v);
            Ok(())
        };
        if let Ok(blocks) = out.cast::<PyDict>() {
            for (k, v) in blocks.iter() {
                let key: String = k.extract()?;
                match key.as_str() {
                    "position_rad" => put(&key, &v, &mut cmd.position_rad)?,
                    "velocity_rad_per_s" => put(&key, &v, &mut cmd.velocity_rad_per_s)?,
                    "intvelocity_rad_per_s" => put(&key, &v, &mut cmd.intvelocity_rad_per_s)?,
                    "torque_nm" => put(&key, &v, &mut cmd.torque_nm)?,
                    other => {
                        return Err(pyo3::exceptions::PyKeyError::new_err(format!(
                            "the controller returned the command block {other:?}; allowed: position_rad, \
                             velocity_rad_per_s, intvelocity_rad_per_s, torque_nm"
                        )));
                    }
                }
            }
            return Ok(());
        }
        let block = match self.method {
            config::ControlMethod::Position => &mut cmd.position_rad,
            config::ControlMethod::Velocity => &mut cmd.velocity_rad_per_s,
            config::ControlMethod::Intvelocity => &mut cmd.intvelocity_rad_per_s,
            config::ControlMethod::Torque => &mut cmd.torque_nm,
        };
        put("command", &out, block)
    }
}

impl Controller for PyController {
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        let failed = self.error.lock().map(|e| e.is_some()).unwrap_or(true);
        let result = if failed { Ok(()) } else { Python::attach(|py| self.call(py, obs, cmd)) };
        if failed || result.is_err() {
            if let (Err(e), Ok(mut slot)) = (result, self.error.lock()) {
                *slot = Some(e);
            }
            for block in
                [&mut cmd.position_rad, &mut cmd.velocity_rad_per_s, &mut cmd.intvelocity_rad_per_s, &mut cmd.torque_nm]
            {
                block.fill(f64::NAN);
            }
        }
    }
}

/// Runs a whole configured simulation (the CLI's `simserpent run`) with the GIL released;
/// returns the summary (with `run_folder`). With `controller` (a Python callable, see
/// `PyController`) it replaces the configured gait.
#[pyfunction]
#[pyo3(signature = (config, run_folder=None, controller=None, progress=None))]
fn run<'py>(
    py: Python<'py>,
    config: &PyConfig,
    run_folder: Option<PathBuf>,
    controller: Option<Py<PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let options = RunOptions {
        on_progress: progress.map(python_progress),
        config_source: config.source.clone(),
        command_line: vec![
            if controller.is_some() { "python: simserpent.run(controller=...)" } else { "python: simserpent.run" }
                .into(),
        ],
        run_folder,
        ..RunOptions::default()
    };
    let c = config.inner.clone();
    let error = Arc::new(Mutex::new(None));
    let result = match controller {
        None => py.detach(move || simserpent::run::run(&c, &options)),
        Some(callable) => {
            let controller = PyController { callable, method: c.control.method, error: Arc::clone(&error) };
            py.detach(move || simserpent::run::run_with_controller(&c, &options, Box::new(controller)))
        }
    };
    if let Some(e) = error.lock().ok().and_then(|mut e| e.take()) {
        let folder = match &result {
            Err(RunError::Sim(SimError::Diverged { time_secs, .. })) => {
                format!(" (the run stopped at t = {time_secs} s)")
            }
            _ => String::new(),
        };
        let wrapped = SimSerpentError::new_err(format!("the Python controller raised an exception{folder}"));
        wrapped.set_cause(py, Some(e));
        return Err(wrapped);
    }
    match result {
        Ok(summary) => summary_dict(py, &summary),
        Err(e) => Err(run_err(&config.source, &e)),
    }
}

/// A Python callable `progress(done, total)` as a progress report. Called with the GIL taken;
/// an exception in it is printed as an unraisable exception (`sys.unraisablehook`) and does not
/// stop the work (progress is only shown).
fn python_progress(callable: Py<PyAny>) -> ProgressCallback {
    let callable = Arc::new(callable);
    ProgressCallback(Arc::new(move |done: u64, total: u64| {
        Python::attach(|py| {
            if let Err(e) = callable.bind(py).call1((done, total)) {
                e.write_unraisable(py, Some(callable.bind(py)));
            }
        });
    }))
}

/// Yaw (rad, in (−π, π]) of an orientation quaternion `(w, x, y, z)`: the heading of the body's
/// +x axis in the floor plane from world +x, counter-clockwise seen from above
/// (`simserpent.head_yaw`).
#[pyfunction]
fn yaw_rad(quat_wxyz: [f64; 4]) -> f64 {
    simserpent::state::yaw_rad(quat_wxyz)
}

/// Each of `names` parsed by `parse`, or an error naming the argument, the unknown `kind` and
/// what is allowed.
fn parse_names<T>(
    argument: &str,
    kind: &str,
    names: &[String],
    parse: fn(&str) -> Option<T>,
    allowed: &str,
) -> PyResult<Vec<T>> {
    names
        .iter()
        .map(|s| {
            parse(s).ok_or_else(|| {
                pyo3::exceptions::PyValueError::new_err(format!("{argument}: unknown {kind} {s:?}; allowed: {allowed}"))
            })
        })
        .collect()
}

/// `simserpent experiment oal-bench` with a Python controller plugged in (the GIL released
/// between its calls): `controller(config)` builds one per run from the run's config (the
/// benchmark's base gait in `gait.sine_wave`, its servos, `estimation.enabled` = `estimation`)
/// and returns the step callable of `PyController`. Writes `<out>/oal-bench-<UTC time>/`
/// (report.md, the tables, plots/); returns `folder` and `report` (Markdown).
#[pyfunction]
#[pyo3(signature = (controller, name, out, quick, estimation, tuning_fields, held_out_fields, duration_secs, floors, families, laws, true_contacts, passive_kp_nm_per_rad, threads, overrides, law_servo_kp_nm_per_rad, progress=None))]
#[allow(clippy::too_many_arguments)]
fn oal_bench<'py>(
    py: Python<'py>,
    controller: Option<Py<PyAny>>,
    name: String,
    out: PathBuf,
    quick: bool,
    estimation: bool,
    tuning_fields: Option<u64>,
    held_out_fields: Option<u64>,
    duration_secs: Option<f64>,
    floors: Option<Vec<String>>,
    families: Option<Vec<String>>,
    laws: bool,
    true_contacts: bool,
    passive_kp_nm_per_rad: Option<Vec<f64>>,
    threads: usize,
    overrides: Vec<String>,
    law_servo_kp_nm_per_rad: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    use simserpent::experiments::oal_bench::{Bench, Family, Floor, Plugged};
    let value_err = pyo3::exceptions::PyValueError::new_err;
    let base = config::load_config_str("", ConfigSource::Toml, &overrides).map_err(|e| config_err("--set", &e))?;
    let mut bench = if quick { Bench::quick() } else { Bench::full() };
    bench.tuning_fields = tuning_fields.unwrap_or(bench.tuning_fields);
    bench.held_out_fields = held_out_fields.unwrap_or(bench.held_out_fields);
    if let Some(d) = duration_secs {
        if !(d.is_finite() && d > 0.0) {
            return Err(value_err(format!("duration_secs = {d}: must be a positive number of seconds")));
        }
        bench.duration_secs = d;
    }
    if let Some(f) = floors {
        bench.floors = parse_names("floors", "floor", &f, Floor::from_name, "\"isotropic\", \"anisotropic\"")?;
    }
    if let Some(f) = families {
        bench.families = parse_names("families", "family", &f, Family::from_name, "\"lattice\", \"random\", \"row\"")?;
    }
    if let Some(kp) = passive_kp_nm_per_rad {
        if kp.iter().any(|k| !(k.is_finite() && *k > 0.0)) {
            return Err(value_err(format!("passive_kp_nm_per_rad = {kp:?}: every gain must be positive")));
        }
        bench.passive_kp_nm_per_rad = kp;
    }
    if let Some(kp) = law_servo_kp_nm_per_rad {
        if !(kp.is_finite() && kp > 0.0) {
            return Err(value_err(format!("law_servo_kp_nm_per_rad = {kp}: must be a positive gain (N·m/rad)")));
        }
        bench.law_servo_kp_nm_per_rad = Some(kp);
    }
    bench.laws = laws;
    bench.true_contacts = true_contacts;
    bench.on_progress = progress.map(python_progress);
    let error: Arc<Mutex<Option<PyErr>>> = Arc::new(Mutex::new(None));
    if let Some(factory) = controller {
        let factory = Arc::new(factory);
        let slot = Arc::clone(&error);
        let make = move |config: &Config, _n_joints: usize| -> Box<dyn Controller> {
            let made = Python::attach(|py| {
                let c = PyConfig { inner: config.clone(), source: "oal-bench field".into() };
                factory.bind(py).call1((c,)).map(Bound::unbind)
            });
            let callable = match made {
                Ok(callable) => callable,
                Err(e) => {
                    // Kept, and the run stops at its first command (NaN).
                    if let Ok(mut s) = slot.lock()
                        && s.is_none()
                    {
                        *s = Some(e);
                    }
                    Python::attach(|py| py.None())
                }
            };
            Box::new(PyController { callable, method: config.control.method, error: Arc::clone(&slot) })
        };
        bench.plugged.push(Plugged { name, make: Arc::new(make), estimation });
    }
    if let Some(message) = simserpent::threads_beyond_cap("threads", threads) {
        return Err(value_err(message));
    }
    bench.check().map_err(|e| value_err(e.to_string()))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| SimSerpentError::new_err(format!("thread pool: {e}")))?;
    let result = py.detach(|| {
        simserpent::experiments::oal_bench::run_into(
            &bench,
            &base,
            &pool,
            &out,
            "Python: `simserpent.oal_bench(...)`",
            false,
        )
    });
    if let Some(e) = error.lock().ok().and_then(|mut e| e.take()) {
        let wrapped = SimSerpentError::new_err("the Python controller raised an exception");
        wrapped.set_cause(py, Some(e));
        return Err(wrapped);
    }
    let (folder, report) = result.map_err(|e| SimSerpentError::new_err(error_text(&e)))?;
    let d = PyDict::new(py);
    d.set_item("folder", folder.display().to_string())?;
    d.set_item("report", report.to_markdown())?;
    Ok(d)
}

/// The config's gait (`[gait]`) as a function of time: `targets(t_secs)` gives the joint
/// target angles (rad) and velocities (rad/s) the built-in controller follows.
#[pyclass(module = "simserpent._core", frozen)]
struct Gait {
    /// Behind a mutex because Python may share the object between threads (the trajectories
    /// are `Send`, not `Sync`).
    trajectory: Mutex<Box<dyn JointTrajectory>>,
    n_joints: usize,
}

#[pymethods]
impl Gait {
    #[new]
    fn new(config: &PyConfig) -> Self {
        let n_joints = config.inner.snake.n_links.saturating_sub(1);
        Gait { trajectory: Mutex::new(simserpent::control::trajectory_from_config(&config.inner)), n_joints }
    }

    /// Joint target angles (rad) and velocities (rad/s) at `t_secs`.
    #[allow(clippy::type_complexity)]
    fn targets<'py>(&self, py: Python<'py>, t_secs: f64) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
        let mut a = vec![0.0; self.n_joints];
        let mut v = vec![0.0; self.n_joints];
        if let Ok(trajectory) = self.trajectory.lock() {
            trajectory.targets(t_secs, &mut a, &mut v);
        }
        (PyArray1::from_vec(py, a), PyArray1::from_vec(py, v))
    }

    #[getter]
    fn n_joints(&self) -> usize {
        self.n_joints
    }
}

fn step_info<'py>(py: Python<'py>, out: &StepOutcome, time_secs: f64) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, value) in RewardTerms::NAMES.iter().zip(out.terms.values()) {
        // The peak force is left out when there is none to read (a diverged step): never a fake 0.
        if value.is_finite() {
            d.set_item(*name, value)?;
        }
    }
    d.set_item("time_secs", time_secs)?;
    if let Some(e) = &out.error {
        d.set_item("error", e)?;
    }
    Ok(d)
}

/// Copies an action (a float64 or float32 numpy array, a list or any sequence of numbers) of
/// exactly `out.len()` values into `out`.
fn read_action(action: &Bound<'_, PyAny>, out: &mut [f64]) -> PyResult<()> {
    let n = out.len();
    let wrong = |got: usize| {
        pyo3::exceptions::PyValueError::new_err(format!("action has {got} values; this snake has {n} joints"))
    };
    if let Ok(a) = action.extract::<PyReadonlyArray1<'_, f64>>() {
        let a = a.as_array();
        if a.len() != n {
            return Err(wrong(a.len()));
        }
        out.iter_mut().zip(a.iter()).for_each(|(o, x)| *o = *x);
    } else if let Ok(a) = action.extract::<PyReadonlyArray1<'_, f32>>() {
        let a = a.as_array();
        if a.len() != n {
            return Err(wrong(a.len()));
        }
        out.iter_mut().zip(a.iter()).for_each(|(o, x)| *o = f64::from(*x));
    } else {
        let v: Vec<f64> = action.extract().map_err(|_| {
            let kind = action.get_type().name().map(|s| s.to_string()).unwrap_or_default();
            // A numpy array: say its dtype and shape (the usual mistakes: strings, objects, 2-D).
            let what = match (action.getattr("dtype"), action.getattr("shape")) {
                (Ok(dtype), Ok(shape)) => format!(
                    "a numpy array of dtype {} and shape {}",
                    dtype.str().map(|s| s.to_string()).unwrap_or_default(),
                    shape.repr().map(|s| s.to_string()).unwrap_or_default()
                ),
                _ => {
                    let shown = action.repr().map(|r| r.to_string()).unwrap_or_default();
                    let shown: String = shown.chars().take(80).collect();
                    format!("{kind} {shown}")
                }
            };
            pyo3::exceptions::PyTypeError::new_err(format!(
                "step: action must be a 1-D array or sequence of {n} real numbers (one per joint), got {what}"
            ))
        })?;
        if v.len() != n {
            return Err(wrong(v.len()));
        }
        out.copy_from_slice(&v);
    }
    Ok(())
}

/// A saved state of a `World` (`World.get_state()`): everything that decides the rest of the
/// trajectory; `World.set_state(state)` continues bit for bit from it.
///
/// It pickles (worker processes, your own replay buffers) as its replay: config, seed, actions.
/// Warning: unpickling runs whatever code a pickle names, so never unpickle a state you did not
/// pickle yourself. To send a state to another machine or read one from others, use
/// `to_bytes()` and `WorldState.from_bytes(data)`: plain data in a versioned layout, checked
/// field by field, never run.
#[pyclass(name = "WorldState", module = "simserpent._core", frozen)]
#[derive(Clone)]
struct PyEnvState {
    inner: EnvState,
    /// How this state was reached (for pickling).
    replay: Replay,
    /// The config of the world it was saved from.
    config: PyConfig,
}

/// How a world reached its state: its config, the seed of its latest reset (`None`: never
/// reset) and every action since, in order (one row of `action_size` values per step). The
/// same config, seed, actions and build give the same state bit for bit, so this is what a
/// saved state pickles to.
#[derive(Clone)]
struct Replay {
    seed: Option<u64>,
    action_size: usize,
    actions: Vec<f64>,
}

/// A pickled [`PyEnvState`] back (and [`PyEnvState::from_bytes`]' fields): builds the world of
/// the config, resets it with the seed, checks the actions (whole steps of the world's action
/// size, finite), replays them and checks that the time and `qpos` reached are the saved ones
/// bit for bit. A malformed state is a `SimSerpentError`, never a panic.
#[pyfunction]
fn _world_state_from_replay(
    py: Python<'_>,
    config_toml: &str,
    source: String,
    seed: Option<u64>,
    actions: Vec<f64>,
    time: f64,
    qpos: Vec<f64>,
) -> PyResult<PyEnvState> {
    let config = _config_from_toml(config_toml, source)?;
    let c = config.inner.clone();
    let mut core = py.detach(|| EnvCore::new(&c)).map_err(|e| sim_err(&config.source, &e))?;
    let na = core.action_size();
    let bad = |what: String| SimSerpentError::new_err(format!("cannot restore the WorldState: {what}"));
    // (`is_multiple_of(0)` holds only for no actions at all.)
    if !actions.len().is_multiple_of(na) {
        return Err(bad(format!(
            "its action list has {} values, not a whole number of steps of this world's {na} actions",
            actions.len()
        )));
    }
    if let Some(i) = actions.iter().position(|a| !a.is_finite()) {
        return Err(bad(format!("action value {i} is {}; actions are finite numbers", actions[i])));
    }
    if !time.is_finite() || qpos.iter().any(|q| !q.is_finite()) {
        return Err(bad("its time or qpos is not finite".into()));
    }
    let inner = py
        .detach(|| -> Result<EnvState, SimError> {
            let mut obs = vec![0.0; core.observation_size()];
            if let Some(seed) = seed {
                core.reset(seed, &mut obs)?;
            }
            for action in actions.chunks_exact(na.max(1)) {
                core.step(action, &mut obs);
            }
            Ok(core.save_state())
        })
        .map_err(|e| sim_err(&config.source, &e))?;
    let data = inner.world().data();
    if data.time().to_bits() != time.to_bits()
        || data.qpos().len() != qpos.len()
        || data.qpos().iter().zip(&qpos).any(|(a, b)| a.to_bits() != b.to_bits())
    {
        return Err(SimSerpentError::new_err(format!(
            "cannot restore the WorldState: replaying its episode (seed {seed:?}, {} steps) reached t = {} s, \
             not the saved t = {time} s (bit for bit); a state is restored by replaying it with the build that \
             saved it (simserpent {}, MuJoCo {})",
            actions.len() / na.max(1),
            data.time(),
            env!("CARGO_PKG_VERSION"),
            mujoco_rs::mujoco_version()
        )));
    }
    Ok(PyEnvState { inner, replay: Replay { seed, action_size: na.max(1), actions }, config })
}

/// The layout of [`PyEnvState::to_bytes`]: this magic, then a little-endian u32 version.
const STATE_MAGIC: &[u8; 16] = b"SimSerpentState\0";
/// The version of the layout written by this build.
const STATE_VERSION: u32 = 1;

/// A reader of [`PyEnvState::to_bytes`]' layout that names the field and the byte offset of
/// whatever is wrong.
struct StateReader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> StateReader<'a> {
    fn bad(&self, what: &str) -> PyErr {
        SimSerpentError::new_err(format!(
            "WorldState.from_bytes: {what} (byte {} of {}); the bytes are not a state written by \
             WorldState.to_bytes()",
            self.at,
            self.bytes.len()
        ))
    }
    fn take(&mut self, n: usize, what: &str) -> PyResult<&'a [u8]> {
        if self.bytes.len() - self.at < n {
            return Err(self.bad(&format!("{what}: cut short")));
        }
        let out = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(out)
    }
    fn u64(&mut self, what: &str) -> PyResult<u64> {
        let b = self.take(8, what)?;
        Ok(u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
    }
    fn f64(&mut self, what: &str) -> PyResult<f64> {
        Ok(f64::from_bits(self.u64(what)?))
    }
    /// A length of `width`-byte items that must fit in the bytes left.
    fn len(&mut self, width: usize, what: &str) -> PyResult<usize> {
        let n = self.u64(what)?;
        let left = (self.bytes.len() - self.at) / width;
        usize::try_from(n)
            .ok()
            .filter(|&n| n <= left)
            .ok_or_else(|| self.bad(&format!("{what}: {n} items, more than the {left} the bytes hold")))
    }
    fn text(&mut self, what: &str) -> PyResult<String> {
        let n = self.len(1, what)?;
        let b = self.take(n, what)?;
        String::from_utf8(b.to_vec()).map_err(|_| self.bad(&format!("{what}: not UTF-8")))
    }
    fn floats(&mut self, what: &str) -> PyResult<Vec<f64>> {
        let n = self.len(8, what)?;
        (0..n).map(|_| self.f64(what)).collect()
    }
}

#[pymethods]
impl PyEnvState {
    /// Pickling: the config, the seed of the episode and its actions (see `Replay`); unpickling
    /// replays them (the same build gives the same state bit for bit, which is checked).
    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (String, String, Option<u64>, Vec<f64>, f64, Vec<f64>))> {
        let f = py.import("simserpent._core")?.getattr("_world_state_from_replay")?;
        let data = self.inner.world().data();
        Ok((
            f,
            (
                self.config.inner.to_toml_string(),
                self.config.source.clone(),
                self.replay.seed,
                self.replay.actions.clone(),
                data.time(),
                data.qpos().to_vec(),
            ),
        ))
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    /// The state as bytes for another process or machine, in a versioned layout that
    /// `WorldState.from_bytes` validates field by field (unlike a pickle, which can run any code
    /// when it is loaded): a 16-byte magic, the version (u32), then little-endian fields: the
    /// config's TOML and its source (u64 length, UTF-8), the seed (u8 0/1, u64), the action size
    /// (u64), the actions (u64 count, f64 each), the time (f64) and `qpos` (u64 count, f64 each).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let data = self.inner.world().data();
        let toml = self.config.inner.to_toml_string();
        let mut out = Vec::with_capacity(64 + toml.len() + 8 * (self.replay.actions.len() + data.qpos().len()));
        out.extend_from_slice(STATE_MAGIC);
        out.extend_from_slice(&STATE_VERSION.to_le_bytes());
        for text in [toml.as_str(), self.config.source.as_str()] {
            out.extend_from_slice(&(text.len() as u64).to_le_bytes());
            out.extend_from_slice(text.as_bytes());
        }
        out.push(u8::from(self.replay.seed.is_some()));
        out.extend_from_slice(&self.replay.seed.unwrap_or(0).to_le_bytes());
        out.extend_from_slice(&(self.replay.action_size as u64).to_le_bytes());
        let floats = |out: &mut Vec<u8>, values: &[f64]| {
            out.extend_from_slice(&(values.len() as u64).to_le_bytes());
            for v in values {
                out.extend_from_slice(&v.to_le_bytes());
            }
        };
        floats(&mut out, &self.replay.actions);
        out.extend_from_slice(&data.time().to_le_bytes());
        floats(&mut out, data.qpos());
        PyBytes::new(py, &out)
    }

    /// A state from `to_bytes()`: every field checked (magic, version, lengths, UTF-8, the
    /// config as any config is, whole steps of finite actions), then the episode replayed with
    /// this build and its time and `qpos` compared bit for bit with the saved ones. Anything
    /// else is a `SimSerpentError` naming the field and byte; nothing in the bytes is run as code.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let mut r = StateReader { bytes: data, at: 0 };
        if !data.starts_with(&STATE_MAGIC[..]) {
            return Err(r.bad("no SimSerpentState magic at the start"));
        }
        r.take(STATE_MAGIC.len(), "magic")?;
        let version = u32::from_le_bytes(r.take(4, "version")?.try_into().unwrap_or([0; 4]));
        if version != STATE_VERSION {
            return Err(r.bad(&format!("layout version {version}; this build reads version {STATE_VERSION}")));
        }
        let toml = r.text("config")?;
        if toml.len() as u64 > simserpent::model::files::MAX_CONFIG_BYTES {
            return Err(r.bad("config: larger than a config may be"));
        }
        let source = simserpent::config::shorten(&r.text("source")?).into_owned();
        let seed = match r.take(1, "seed flag")?[0] {
            0 => None,
            1 => Some(r.u64("seed")?),
            flag => return Err(r.bad(&format!("seed flag {flag}: 0 or 1"))),
        };
        if seed.is_none() {
            r.u64("seed")?;
        }
        let action_size = r.u64("action size")?;
        let actions = r.floats("actions")?;
        let time = r.f64("time")?;
        let qpos = r.floats("qpos")?;
        if r.at != data.len() {
            return Err(r.bad(&format!("{} bytes after the last field", data.len() - r.at)));
        }
        let state = _world_state_from_replay(py, &toml, source, seed, actions, time, qpos)?;
        if state.replay.action_size as u64 != action_size.max(1) {
            return Err(SimSerpentError::new_err(format!(
                "WorldState.from_bytes: action size {action_size}, but the config's world has {}",
                state.replay.action_size
            )));
        }
        Ok(state)
    }

    /// Number of actions since the episode's reset (what unpickling replays).
    #[getter]
    fn steps(&self) -> usize {
        self.replay.actions.len() / self.replay.action_size.max(1)
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.inner.world().data().time()
    }
    /// MuJoCo's joint positions (the head's free joint first: x, y, z, quaternion w x y z).
    #[getter]
    fn qpos<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.inner.world().data().qpos())
    }
    /// MuJoCo's joint velocities.
    #[getter]
    fn qvel<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.inner.world().data().qvel())
    }
}

/// One environment (the core of `simserpent.SimSerpentEnv`).
#[pyclass(module = "simserpent._core")]
struct Env {
    core: EnvCore,
    obs: Vec<f64>,
    /// The action, copied out of the numpy array so the step can run without the GIL.
    action: Vec<f64>,
    source: String,
    config: PyConfig,
    /// The seed of the latest reset and the actions since (for pickling saved states).
    replay: Replay,
}

#[pymethods]
impl Env {
    #[new]
    fn new(config: &Bound<'_, PyAny>) -> PyResult<Self> {
        let config = config.cast::<PyConfig>().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "World(config): config must be a simserpent.Config (from simserpent.load_config(...); \
                 simserpent.make_world(path_or_dict) loads one), got {}",
                describe(config)
            ))
        })?;
        let config = config.get();
        let core = EnvCore::new(&config.inner).map_err(|e| sim_err(&config.source, &e))?;
        let obs = vec![0.0; core.observation_size()];
        let na = core.action_size();
        let action = vec![0.0; na];
        Ok(Self {
            core,
            obs,
            action,
            source: config.source.clone(),
            config: config.clone(),
            replay: Replay { seed: None, action_size: na, actions: Vec::new() },
        })
    }

    /// Starts an episode with the sensor- and reset-noise seed `seed` (0 to 2**64 - 1); returns
    /// the first observation.
    fn reset<'py>(&mut self, py: Python<'py>, seed: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let seed = seed_arg("World.reset", seed)?;
        self.core.reset(seed, &mut self.obs).map_err(|e| sim_err(&self.source, &e))?;
        self.replay.seed = Some(seed);
        self.replay.actions.clear();
        // Room for a whole episode's actions (at most 8 MB), so steps do not allocate.
        let episode = usize::try_from(self.core.max_episode_steps()).unwrap_or(usize::MAX);
        self.replay.actions.reserve(episode.saturating_mul(self.replay.action_size).min(1 << 20));
        Ok(PyArray1::from_slice(py, &self.obs))
    }

    /// Holds `action` for one control period: (observation, reward, terminated, truncated, info).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, f64, bool, bool, Bound<'py, PyDict>)> {
        read_action(action, &mut self.action)?;
        // The physics runs without the GIL: other Python threads (e.g. one env per thread) go on.
        let Self { core, obs, action, replay, .. } = self;
        replay.actions.extend_from_slice(action);
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
    /// Centre of mass of the links at the start of the episode (m; restored by `set_state`).
    #[getter]
    fn start_centre_of_mass(&self) -> [f64; 3] {
        self.core.start_centre_of_mass()
    }
    /// The forward direction of the reward (x, y).
    #[getter]
    fn forward_xy(&self) -> [f64; 2] {
        self.core.forward_xy()
    }
    /// The physical bounds (rad or N m) a normalised action maps onto.
    #[getter]
    fn physical_action_low<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.physical_action_bounds().0)
    }
    #[getter]
    fn physical_action_high<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.physical_action_bounds().1)
    }
    /// Whether actions are normalised to [-1, 1].
    #[getter]
    fn normalize_action(&self) -> bool {
        self.core.config().env.normalize_action
    }
    /// The true state: simulated time (s) (MuJoCo's `data.time`).
    #[getter]
    fn time(&self) -> f64 {
        self.core.world().data().time()
    }
    /// The true state: MuJoCo's `qpos` (a copy; the head's free joint first).
    #[getter]
    fn qpos<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.world().data().qpos())
    }
    /// The true state: MuJoCo's `qvel` (a copy).
    #[getter]
    fn qvel<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.world().data().qvel())
    }
    /// The true state: MuJoCo's `act` (actuator activations; empty for the snake's actuators).
    #[getter]
    fn act<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.world().data().act())
    }
    /// MuJoCo's `ctrl` of the last step (a copy).
    #[getter]
    fn ctrl<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.world().data().ctrl())
    }
    /// MuJoCo's `qacc_warmstart` (part of the integration state).
    #[getter]
    fn qacc_warmstart<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.core.world().data().qacc_warmstart())
    }
    /// Every element of MuJoCo's `mjSTATE_INTEGRATION` state (time, qpos, qvel, act,
    /// warm start, ctrl, applied forces, …) in MuJoCo's order: what `mujoco.mj_setState`
    /// takes.
    fn integration_state<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let spec = mujoco_rs::mujoco_c::mjtState::mjSTATE_INTEGRATION as u32;
        PyArray1::from_slice(py, &self.core.world().data().state(spec))
    }
    /// The contact estimates of the latest sensed instant (`[estimation] enabled`; otherwise
    /// `active` is False and all zero): a dict of numpy arrays, see `estimates_dict`.
    fn contact_estimates<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        estimates_dict(py, self.core.contact_estimates())
    }
    /// A copy of the whole state (engine, held action, sensor-noise streams, ground model,
    /// episode bookkeeping). It pickles for your own processes (never unpickle a state from
    /// others: unpickling runs code); `to_bytes()` / `WorldState.from_bytes()` carry it across
    /// machines as checked plain data.
    fn get_state(&self) -> PyEnvState {
        PyEnvState { inner: self.core.save_state(), replay: self.replay.clone(), config: self.config.clone() }
    }
    /// Goes back to a state from `get_state` (of this world or one of the same config): the
    /// same actions then give the same trajectory bit for bit.
    fn set_state(&mut self, state: &Bound<'_, PyAny>) -> PyResult<()> {
        let state = state.cast::<PyEnvState>().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "World.set_state: state must be a WorldState from World.get_state(), got {}",
                describe(state)
            ))
        })?;
        let state = state.get();
        self.core.restore_state(&state.inner).map_err(|e| sim_err(&self.source, &e))?;
        self.replay.clone_from(&state.replay);
        Ok(())
    }
}

/// Number of reward terms per environment in the vector environment's terms array.
const N_TERMS: usize = RewardTerms::NAMES.len();

/// One environment's buffers in the vector environment's step.
struct Slot<'a> {
    env: &'a mut EnvCore,
    obs: &'a mut [f64],
    final_obs: &'a mut [f64],
    action: &'a [f64],
    reward: &'a mut f64,
    terms: &'a mut [f64],
    terminated: &'a mut bool,
    truncated: &'a mut bool,
    error: &'a mut Option<String>,
    needs_reset: &'a mut bool,
    was_reset: &'a mut bool,
    next_seed: u64,
}

/// Many environments stepped together in Rust on a rayon pool, with the GIL released
/// (the core of `simserpent.SimSerpentVectorEnv`). Automatic reset: `same_step` (an
/// environment whose episode ends is reset in the same step; its last observation goes to
/// the final-observation buffer) or next step (Gymnasium's `NEXT_STEP`: the step after an
/// episode ends resets it instead of stepping). The seed of an automatic reset is given by
/// the caller with every step, so seeds follow the caller's per-environment generators.
#[pyclass(module = "simserpent._core")]
struct VecEnv {
    envs: Vec<EnvCore>,
    pool: rayon::ThreadPool,
    same_step: bool,
    obs: Vec<f64>,
    final_obs: Vec<f64>,
    rewards: Vec<f64>,
    terms: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    errors: Vec<Option<String>>,
    needs_reset: Vec<bool>,
    was_reset: Vec<bool>,
    actions: Vec<f64>,
    next_seeds: Vec<u64>,
    source: String,
}

fn step_slot(s: Slot<'_>, same_step: bool) {
    let Slot {
        env,
        obs,
        final_obs,
        action,
        reward,
        terms,
        terminated,
        truncated,
        error,
        needs_reset,
        was_reset,
        next_seed,
    } = s;
    *was_reset = false;
    if *needs_reset {
        // NEXT_STEP: this step only resets.
        *error = env.reset(next_seed, obs).err().map(|e| e.to_string());
        *reward = 0.0;
        terms.fill(0.0);
        terms[RewardTerms::NAMES.iter().position(|n| *n == "peak_contact_force_n").unwrap_or(0)] = f64::NAN;
        *terminated = error.is_some();
        *truncated = false;
        *needs_reset = *terminated;
        *was_reset = true;
        return;
    }
    let out = env.step(action, obs);
    *reward = out.reward;
    terms.copy_from_slice(&out.terms.values());
    *terminated = out.terminated;
    *truncated = out.truncated;
    *error = out.error;
    let done = out.terminated || out.truncated;
    if done && same_step {
        final_obs.copy_from_slice(obs);
        if let Err(e) = env.reset(next_seed, obs) {
            *error = Some(e.to_string());
            *needs_reset = true;
        }
        *was_reset = true;
    } else {
        *needs_reset = done;
    }
}

/// Most environments of one [`VecEnv`]: each holds a MuJoCo model and data of its own.
const MAX_ENVS: usize = 4096;

#[pymethods]
impl VecEnv {
    /// `num_envs` copies of the environment of `config`, stepped on `threads` threads (0: all
    /// cores); `autoreset_mode` `"next_step"` or `"same_step"`.
    #[new]
    #[pyo3(signature = (config, num_envs, threads=0, autoreset_mode="next_step"))]
    fn new(py: Python<'_>, config: &PyConfig, num_envs: usize, threads: usize, autoreset_mode: &str) -> PyResult<Self> {
        if !(1..=MAX_ENVS).contains(&num_envs) {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "num_envs = {num_envs}: give 1 to {MAX_ENVS} environments (each holds its own MuJoCo model and data)"
            )));
        }
        if let Some(message) = simserpent::threads_beyond_cap("threads", threads) {
            return Err(pyo3::exceptions::PyValueError::new_err(message));
        }
        let same_step = match autoreset_mode {
            "next_step" => false,
            "same_step" => true,
            other => {
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "autoreset_mode {other:?} is not supported; allowed: \"next_step\", \"same_step\""
                )));
            }
        };
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
            same_step,
            obs: vec![0.0; n * no],
            final_obs: vec![0.0; n * no],
            rewards: vec![0.0; n],
            terms: vec![0.0; n * N_TERMS],
            terminated: vec![false; n],
            truncated: vec![false; n],
            errors: vec![None; n],
            needs_reset: vec![false; n],
            was_reset: vec![false; n],
            actions: vec![0.0; n * envs[0].action_size()],
            next_seeds: vec![0; n],
            envs,
            source: config.source.clone(),
        })
    }

    /// Resets environment i with `seeds[i]` where `mask[i]` (every environment without a
    /// mask); the others keep their state and observation. Returns all observations.
    #[pyo3(signature = (seeds, mask=None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seeds: Vec<u64>,
        mask: Option<Vec<bool>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.envs.len();
        let no = self.obs.len() / n;
        let mask = mask.unwrap_or_else(|| vec![true; n]);
        if seeds.len() != n || mask.len() != n {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "reset got {} seeds and {} mask values; expected {n} of each",
                seeds.len(),
                mask.len()
            )));
        }
        for (needs_reset, reset) in self.needs_reset.iter_mut().zip(&mask) {
            if *reset {
                *needs_reset = false;
            }
        }
        let (envs, obs, pool) = (&mut self.envs, &mut self.obs, &self.pool);
        let result: Result<(), SimError> = py.detach(|| {
            pool.install(|| {
                envs.par_iter_mut()
                    .zip(obs.par_chunks_mut(no))
                    .zip(seeds.par_iter().zip(mask.par_iter()))
                    .try_for_each(|((env, o), (s, m))| if *m { env.reset(*s, o) } else { Ok(()) })
            })
        });
        result.map_err(|e| sim_err(&self.source, &e))?;
        PyArray1::from_slice(py, &self.obs).reshape([n, no])
    }

    /// Steps every environment with its row of `actions` (num_envs x action_size, float64 or
    /// float32); `next_seeds[i]` seeds environment i if it is reset automatically in this step.
    /// Returns (observations, rewards, terminated, truncated, reward terms (num_envs x
    /// len(TERM_NAMES)), errors, reset mask, final observations (same_step mode; the rows of
    /// the reset environments hold their episode's last observation)).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
        next_seeds: Vec<u64>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyList>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray2<f64>>,
    )> {
        let n = self.envs.len();
        let na = self.envs[0].action_size();
        let no = self.obs.len() / n;
        if next_seeds.len() != n {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "next_seeds has {} values; expected {n}",
                next_seeds.len()
            )));
        }
        self.next_seeds.copy_from_slice(&next_seeds);
        let bad_shape = |shape: &[usize]| {
            pyo3::exceptions::PyValueError::new_err(format!("actions have shape {shape:?}; expected ({n}, {na})"))
        };
        if let Ok(a) = actions.extract::<PyReadonlyArray2<'_, f64>>() {
            if a.shape() != [n, na] {
                return Err(bad_shape(a.shape()));
            }
            self.actions.iter_mut().zip(a.as_array().iter()).for_each(|(d, x)| *d = *x);
        } else if let Ok(a) = actions.extract::<PyReadonlyArray2<'_, f32>>() {
            if a.shape() != [n, na] {
                return Err(bad_shape(a.shape()));
            }
            self.actions.iter_mut().zip(a.as_array().iter()).for_each(|(d, x)| *d = f64::from(*x));
        } else {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "actions must be a 2-D float64 or float32 numpy array of shape ({n}, {na})"
            )));
        }
        let sequential = self.pool.current_num_threads() == 1;
        let same_step = self.same_step;
        let Self {
            envs,
            pool,
            obs,
            final_obs,
            rewards,
            terms,
            terminated,
            truncated,
            errors,
            needs_reset,
            was_reset,
            actions,
            next_seeds,
            ..
        } = self;
        py.detach(|| {
            let all: Vec<Slot<'_>> = envs
                .iter_mut()
                .zip(obs.chunks_mut(no))
                .zip(final_obs.chunks_mut(no))
                .zip(actions.chunks(na))
                .zip(rewards.iter_mut())
                .zip(terms.chunks_mut(N_TERMS))
                .zip(terminated.iter_mut())
                .zip(truncated.iter_mut())
                .zip(errors.iter_mut())
                .zip(needs_reset.iter_mut())
                .zip(was_reset.iter_mut())
                .zip(next_seeds.iter())
                .map(
                    |(
                        (
                            (
                                (
                                    (((((((env, obs), final_obs), action), reward), terms), terminated), truncated),
                                    error,
                                ),
                                needs_reset,
                            ),
                            was_reset,
                        ),
                        next_seed,
                    )| Slot {
                        env,
                        obs,
                        final_obs,
                        action,
                        reward,
                        terms,
                        terminated,
                        truncated,
                        error,
                        needs_reset,
                        was_reset,
                        next_seed: *next_seed,
                    },
                )
                .collect();
            if sequential {
                // One thread: step in this thread, no hand-over to the pool.
                all.into_iter().for_each(|s| step_slot(s, same_step));
            } else {
                // One rayon task per environment: an idle thread takes over the environments of
                // a thread that the OS preempted (the step waits for the slowest thread).
                pool.install(|| all.into_par_iter().with_max_len(1).for_each(|s| step_slot(s, same_step)));
            }
        });
        let errors = PyList::new(py, self.errors.iter().cloned())?;
        Ok((
            PyArray1::from_slice(py, &self.obs).reshape([n, no])?,
            PyArray1::from_slice(py, &self.rewards),
            PyArray1::from_slice(py, &self.terminated),
            PyArray1::from_slice(py, &self.truncated),
            PyArray1::from_slice(py, &self.terms).reshape([n, N_TERMS])?,
            errors,
            PyArray1::from_slice(py, &self.was_reset),
            PyArray1::from_slice(py, &self.final_obs).reshape([n, no])?,
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
    fn autoreset_mode(&self) -> &'static str {
        if self.same_step { "same_step" } else { "next_step" }
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

/// A panel `plot_run_folder` left out: (panel, why).
type SkippedPanel = (String, String);

/// `simserpent plot RUN_FOLDER` (with the GIL released): the standard panels as PNG and SVG into
/// `RUN_FOLDER/plots/`. Returns (files written, [(panel, why it was left out)]).
#[pyfunction]
fn plot_run_folder(py: Python<'_>, run_folder: PathBuf) -> PyResult<(Vec<String>, Vec<SkippedPanel>)> {
    let out =
        py.detach(|| simserpent::plot::plot_run_folder(&run_folder)).map_err(|e| PlotError::new_err(error_text(&e)))?;
    Ok((out.files.iter().map(|f| f.display().to_string()).collect(), out.skipped))
}

/// `simserpent render RUN_FOLDER [--video] [--images] [--set ...]` (with the GIL released): replays
/// the run's `state.csv` into a video and/or the images at `render.image_times_secs`. Returns the
/// files written.
#[pyfunction]
#[pyo3(signature = (run_folder, video, images, overrides=Vec::new()))]
fn render_run_folder(
    py: Python<'_>,
    run_folder: PathBuf,
    video: bool,
    images: bool,
    overrides: Vec<String>,
) -> PyResult<Vec<String>> {
    if !video && !images {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "render: nothing to render; give video=True and/or images=True",
        ));
    }
    let options = simserpent::render::ReplayOptions { video, images, overrides, progress: false };
    let files = py.detach(|| simserpent::render::render_run_folder(&run_folder, &options)).map_err(|e| match e {
        simserpent::render::RenderError::Config { .. } => ConfigError::new_err(error_text(&e)),
        _ => RenderError::new_err(error_text(&e)),
    })?;
    Ok(files.iter().map(|f| f.display().to_string()).collect())
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // MuJoCo's fatal errors end a run as the command line ends it (a `failed` manifest naming
    // the error and the simulated time, every table flushed to the same instant) instead of
    // MuJoCo's own handler, which exits with nothing written; its warnings go to the log.
    // SAFETY: the module is initialised once, under the GIL, before any of its functions can
    // use this library's MuJoCo (the `mujoco` package loads its own copy, untouched).
    #[allow(unsafe_code)]
    unsafe {
        simserpent::sim::fatal::install();
    }
    m.add("SimSerpentError", py.get_type::<SimSerpentError>())?;
    m.add("ConfigError", py.get_type::<ConfigError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("RecordError", py.get_type::<RecordError>())?;
    m.add("SweepError", py.get_type::<SweepError>())?;
    m.add("EstimateError", py.get_type::<EstimateError>())?;
    m.add("RenderError", py.get_type::<RenderError>())?;
    m.add("PlotError", py.get_type::<PlotError>())?;
    m.add_class::<PyConfig>()?;
    m.add_class::<Env>()?;
    m.add_class::<VecEnv>()?;
    m.add_class::<Sweep>()?;
    m.add_class::<Gait>()?;
    m.add_class::<PyEnvState>()?;
    m.add_function(wrap_pyfunction!(_config_from_toml, m)?)?;
    m.add_function(wrap_pyfunction!(_world_state_from_replay, m)?)?;
    m.add_function(wrap_pyfunction!(plot_run_folder, m)?)?;
    m.add_function(wrap_pyfunction!(render_run_folder, m)?)?;
    m.add("TERM_NAMES", RewardTerms::NAMES.to_vec())?;
    m.add("ENV_FAST_PRESET", config::ENV_FAST_PRESET.to_vec())?;
    m.add_function(wrap_pyfunction!(load_config, m)?)?;
    m.add_function(wrap_pyfunction!(default_config_toml, m)?)?;
    m.add_function(wrap_pyfunction!(mujoco_version, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(estimate, m)?)?;
    m.add_function(wrap_pyfunction!(oal_bench, m)?)?;
    m.add_function(wrap_pyfunction!(yaw_rad, m)?)?;
    m.add("SWEEP_METRICS", sweep::METRICS.iter().map(|m| m.name).collect::<Vec<_>>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

//! One whole run: build the world, create the run folder, step and record, summarise.

use crate::config::Config;
use crate::control::Controller;
use crate::record::{self, Manifest, RecordError, Recorder, RunStatus, SpaceReserve};
use crate::sim::{Every, LoopPlan, Observer, SimError, Simulation, StepView, World};
use crate::state::{RunTotals, Snapshot};
use std::cell::RefCell;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// What to run, beyond the config.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Where the config came from, for the manifest.
    pub config_source: String,
    /// A user's robot (MJCF or URDF) instead of the generated snake.
    pub robot: Option<PathBuf>,
    /// The command line, for the manifest.
    pub command_line: Vec<String>,
    /// Show a progress bar on runs that take more than two seconds (only on a terminal).
    pub progress: bool,
    /// Called with (steps done, steps in all) every 1024 steps and once at the end (Python's
    /// `simserpent.run(progress=...)`).
    pub on_progress: Option<ProgressCallback>,
    /// Show the run in MuJoCo's interactive viewer (live with the `viewer` feature; see
    /// [`crate::render::viewer`]). Fails before the run when there is no display.
    pub viewer: bool,
    /// Record into exactly this folder (created if missing) instead of a new
    /// `<output_dir>/<run_name>-<UTC time>/`; sweeps use it for deterministic run folders.
    pub run_folder: Option<PathBuf>,
    /// The live ROS 2 bridge (`run --ros2`, cargo feature `ros2`; user guide, "ROS 2"): the run
    /// publishes its topics over DDS and takes its joint commands from ROS 2 (the built-in
    /// controller is not used).
    pub ros2: bool,
    /// Write the tables, the ROS 2 bag and `state.csv` on the step-loop thread instead of on
    /// writer threads (`record::offload`). The files are byte for byte the same; this is the
    /// synchronous path, for comparisons (`simserpent bench --inline-writers`) and tests.
    pub inline_writers: bool,
}

/// A caller's progress report: called with (done, in all) — steps of a run, runs of a
/// benchmark — from the thread that did the work.
#[derive(Clone)]
pub struct ProgressCallback(pub std::sync::Arc<dyn Fn(u64, u64) + Send + Sync>);

impl ProgressCallback {
    /// Reports `done` of `total`.
    pub fn report(&self, done: u64, total: u64) {
        (self.0)(done, total);
    }
}

impl std::fmt::Debug for ProgressCallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ProgressCallback")
    }
}

/// Errors of a run (the binary maps them to the documented exit codes).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
    /// Building the world or stepping it failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Writing the run folder failed.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// State recording, images, video or the viewer failed.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// Plotting after the run (`general.plot = true`) failed.
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    /// SIGINT/SIGTERM (or [`crate::interrupt::request`]) stopped the run; the tables hold every
    /// row recorded up to then and the manifest says `incomplete` (exit code 130).
    #[error(
        "interrupted by a signal (SIGINT or SIGTERM) at t = {time_secs:.6} s (step {step}); the tables hold every \
         row recorded up to then"
    )]
    Interrupted {
        /// Simulated time reached.
        time_secs: f64,
        /// Steps taken.
        step: u64,
    },
    /// SIGINT/SIGTERM arrived during set-up (reading the config, generating and compiling the
    /// model): the run stopped before its run folder was created (exit code 130).
    #[error(
        "interrupted by a signal (SIGINT or SIGTERM) during set-up, before the run started; no run folder was created"
    )]
    InterruptedSetUp,
    /// The run folder is held by another process (a run into the same folder, or a
    /// `bag-repair` of it), or its lock cannot be taken.
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// The live ROS 2 bridge failed, or a lockstep peer went silent
    /// ([`crate::ros2::Ros2Error::PeerTimeout`]: manifest `incomplete`, the tables readable).
    #[error(transparent)]
    Ros2(#[from] crate::ros2::Ros2Error),
}

pub use crate::record::RunSummary;

/// Builds the world described by `config` (and `options.robot`). Fails before anything is
/// written, so a bad config or robot never leaves a run folder behind.
pub fn build_world(config: &Config, options: &RunOptions) -> Result<World, SimError> {
    let progress = crate::setup_progress::SetupProgress::start(options.progress, "generating the model");
    // A fatal MuJoCo error from here to the end of set-up names the file (exit code 2).
    let _fatal = crate::sim::fatal::set_up(match &options.robot {
        Some(robot) => format!("robot file {}", robot.display()),
        None if options.config_source.is_empty() => "the model generated from the config".to_string(),
        None => format!("the model generated from config {}", options.config_source),
    });
    match &options.robot {
        None => {
            let generated = crate::model::generate(config)?;
            progress.phase("compiling the model (MuJoCo)");
            World::from_generated(config, generated)
        }
        Some(robot) => {
            progress.phase("loading the robot and compiling the model (MuJoCo)");
            // Private (random name, 0700), removed when dropped: see `sim::scratch_dir`.
            let scratch = crate::sim::scratch_dir("robot")?;
            World::from_robot_file(config, robot, scratch.path())
        }
    }
}

/// Runs the built-in controller of `config`; the summary reports how well the joints tracked
/// the gait ([`RunSummary::tracking`]).
pub fn run(config: &Config, options: &RunOptions) -> Result<RunSummary, RunError> {
    let world = build_world(config, options)?;
    if options.ros2 {
        // The live bridge: its commands drive the joints (user guide, "ROS 2").
        let (mut bridge, source) = crate::ros2::open_bridge(config, &world.index)?;
        let sim = Simulation::with_controller(config, world, Box::new(source));
        return run_simulation_tracked(config, options, sim, None, Some(bridge.as_mut()));
    }
    let sim = Simulation::new(config, world);
    let tracking = Tracking::new(config, sim.world());
    run_simulation_tracked(config, options, sim, tracking, None)
}

/// Whether a run ended before the gait's ramp-in did: its tracking figures then cover the ramp-in
/// (the command still growing from rest), and no tracking warning is given.
pub fn ended_in_ramp_in(config: &Config, summary: &RunSummary) -> bool {
    summary.simulated_secs < config.gait.ramp_secs
}

/// The tracking warning of a summary: which joints missed their command (see
/// [`crate::state::JointTracking::tracks`]), by how much, and what to change; `None` when every
/// joint tracked, nothing was commanded, or the run ended during the ramp-in
/// ([`ended_in_ramp_in`]).
pub fn tracking_warning(config: &Config, summary: &RunSummary) -> Option<String> {
    use crate::config::ControlMethod;
    if ended_in_ramp_in(config, summary) {
        return None;
    }
    let joints = summary.tracking.as_deref()?;
    let missed: Vec<&crate::state::JointTracking> = joints.iter().filter(|j| !j.tracks()).collect();
    let worst = missed.iter().max_by(|a, b| a.rms_error_percent.total_cmp(&b.rms_error_percent))?;
    let c = &config.control;
    let gain = match c.method {
        ControlMethod::Position => format!(
            "control.position_kp_nm_per_rad = {} (and position_kv_nm_s_per_rad = {})",
            c.position_kp_nm_per_rad, c.position_kv_nm_s_per_rad
        ),
        ControlMethod::Velocity => format!("control.velocity_kv_nm_s_per_rad = {}", c.velocity_kv_nm_s_per_rad),
        ControlMethod::Intvelocity => format!("control.intvelocity_kp_nm_per_rad = {}", c.intvelocity_kp_nm_per_rad),
        ControlMethod::Torque => format!(
            "control.pid_kp_nm_per_rad = {}, pid_kd_nm_s_per_rad = {}",
            c.pid_kp_nm_per_rad, c.pid_kd_nm_s_per_rad
        ),
    };
    let [lo, hi] = crate::state::TRACKING_AMPLITUDE_PERCENT;
    let obstacles = if summary.obstacle_contact_secs > 0.0 {
        format!(
            "; but first: the snake touched obstacles for {:.1} s of the run, and a joint whose links press against \
             an obstacle cannot follow its command whatever the gain (control.controller = \"path_following\" keeps \
             the default snake inside its corridor)",
            summary.obstacle_contact_secs
        )
    } else {
        String::new()
    };
    Some(format!(
        "the joints do not track their commanded angles: {} of {} joints miss it (reached amplitude outside {lo}–{hi} % or RMS \
         error above {} % of the command amplitude); worst {}: reached {:.0} % of the commanded ±{:.2}°, RMS \
         error {:.0} %, max {:.0} %. The servos cannot follow these commands with {gain} and \
         snake.torque_range_nm = {:?}: raise the gain (or the torque range), or slow the gait down{obstacles}",
        missed.len(),
        joints.len(),
        crate::state::TRACKING_RMS_ERROR_PERCENT,
        crate::config::shorten(&worst.joint),
        worst.reached_amplitude_percent,
        worst.command_amplitude_rad.to_degrees(),
        worst.rms_error_percent,
        worst.max_error_percent,
        config.snake.torque_range_nm,
    ))
}

/// Names in a message, capped as errors cap what they echo: each at most
/// [`crate::config::ECHO_LIMIT`] characters, at most 10 of them and a count of the rest.
pub fn echo_names(names: &[&str]) -> String {
    const SHOWN: usize = 10;
    let mut text =
        names.iter().take(SHOWN).map(|n| crate::config::shorten(n).into_owned()).collect::<Vec<_>>().join(", ");
    if names.len() > SHOWN {
        text.push_str(&format!(", … and {} more", names.len() - SHOWN));
    }
    text
}

/// What the user should know about the set-up of a run ([`RunSummary::notes`]): a robot's
/// joints that no actuator drives.
fn setup_notes(config: &Config, options: &RunOptions, world: &World) -> Vec<String> {
    let passive = world.passive_joints();
    match &options.robot {
        Some(robot) if !passive.is_empty() && !config.robot.position_servos => vec![format!(
            "{} of the {} joints of {} have no actuator ({}): they are passive, moved only by gravity and contacts, \
             whatever the controller commands (a URDF has no actuators); robot.position_servos = true gives each a \
             position servo (control.position_kp_nm_per_rad, control.position_kv_nm_s_per_rad, \
             snake.torque_range_nm)",
            passive.len(),
            world.n_joints(),
            crate::config::shorten(&robot.display().to_string()),
            echo_names(&passive)
        )],
        _ => Vec::new(),
    }
}

/// Runs a user's controller on the world of `config`.
pub fn run_with_controller(
    config: &Config,
    options: &RunOptions,
    controller: Box<dyn Controller>,
) -> Result<RunSummary, RunError> {
    let world = build_world(config, options)?;
    let sim = Simulation::with_controller(config, world, controller);
    run_simulation(config, options, sim)
}

/// Runs a prepared simulation for the configured duration, recording into a new run folder.
///
/// A stop requested during set-up ([`crate::interrupt`]; a model compile can take many seconds)
/// is acted on here, before the run folder is created. From the moment the folder exists it
/// holds a `manifest.json` (see [`open_run_folder`]), and whatever ends the run — the end of
/// the duration, divergence, a full disk, a signal — leaves one that says how.
pub fn run_simulation<C: Controller>(
    config: &Config,
    options: &RunOptions,
    sim: Simulation<C>,
) -> Result<RunSummary, RunError> {
    run_simulation_tracked(config, options, sim, None, None)
}

/// [`run_simulation`], with the joints' tracking of the configured gait measured when `tracking`
/// is given (only meaningful for the built-in controller, which follows that gait), and the live
/// ROS 2 bridge as an observer when given (its report goes into the manifest).
fn run_simulation_tracked<C: Controller>(
    config: &Config,
    options: &RunOptions,
    mut sim: Simulation<C>,
    mut tracking: Option<Tracking>,
    mut bridge: Option<&mut dyn crate::ros2::LiveBridge>,
) -> Result<RunSummary, RunError> {
    if crate::interrupt::requested() {
        return Err(RunError::InterruptedSetUp);
    }
    let unix_secs = SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let stamp = record::utc_stamp(unix_secs);
    let (folder, created) = match &options.run_folder {
        Some(folder) => {
            let existed = folder.exists();
            std::fs::create_dir_all(folder).map_err(record::io_err(folder))?;
            (folder.clone(), !existed)
        }
        None => {
            let output_dir = Path::new(&config.general.output_dir);
            (record::create_run_folder(output_dir, &config.general.run_name, &stamp)?, true)
        }
    };
    // Held until the run ends: `bag-repair` refuses a folder whose run is still going on, and a
    // second run into the same folder refuses at once.
    let _lock = crate::files::RunLock::try_acquire(&folder).map_err(|e| {
        if created {
            let _ = std::fs::remove_dir_all(&folder);
        }
        RunError::File(e)
    })?;
    let dt = config.general.timestep_secs;
    let total_steps = (config.general.duration_secs / dt).round().max(1.0) as u64;
    let mut manifest = Manifest {
        simserpent_version: env!("CARGO_PKG_VERSION").to_string(),
        mujoco_version: crate::sim::engine_version(),
        mujoco_rs_version: crate::sim::BINDING_VERSION.to_string(),
        seed: config.general.seed,
        status: RunStatus::Incomplete,
        error: None,
        started_utc: stamp,
        wall_time_secs: 0.0,
        steps: 0,
        simulated_secs: 0.0,
        duration_secs: config.general.duration_secs,
        record_every_n_steps: config.recording.every_n_steps,
        command_line: options.command_line.clone(),
        config_source: options.config_source.clone(),
        robot_file: options.robot.as_ref().map(|p| p.display().to_string()),
        tables: Vec::new(),
        mujoco_warnings: Vec::new(),
        summary: None,
        plots: None,
        ros2: None,
    };
    let mut reserve = open_run_folder(&folder, created, &mut manifest)?;
    let set_up = write_run_files(config, &folder, sim.world()).and_then(|()| {
        let format = config.recording.format;
        let threaded = !options.inline_writers;
        let recorder = if config.recording.enabled && (format.csv() || format.parquet()) {
            let surfaces = !sim.ground().surfaces().is_empty();
            Some(Recorder::create(
                &folder,
                &config.recording,
                &sim.world().index,
                surfaces,
                config.estimation.enabled,
                threaded,
            )?)
        } else {
            None
        };
        // The ROS 2 bag (user guide, "ROS 2").
        let bag = if config.recording.enabled && format.mcap() {
            Some(crate::ros2::BagRecorder::create(&folder, config, &sim.world().index, threaded)?)
        } else {
            None
        };
        let visuals = crate::render::RunVisuals::create(config, &folder, sim.world().data(), options.viewer, threaded)?;
        Ok((recorder, bag, visuals))
    });
    let (recorder, bag, visuals) = match set_up {
        Ok(parts) => parts,
        Err(e) => return Err(end_unfinished(&folder, &mut manifest, &mut reserve, e)),
    };
    if bag.is_some() {
        // The bag is listed from the start (0 instants while the manifest says `incomplete`): a
        // killed run's manifest names it, and `simserpent bag-repair` makes it readable.
        manifest.tables = vec![(crate::ros2::bag::FILE_NAME.to_string(), 0)];
        if let Err(e) = manifest.write(&folder) {
            return Err(end_unfinished(&folder, &mut manifest, &mut reserve, e.into()));
        }
    }

    // Shared with the finisher of a fatal MuJoCo error (`sim::fatal`), which ends the run from
    // inside MuJoCo's error handler: the step loop borrows each only while it calls it.
    let (recorder, bag, visuals) = (Shared::new(recorder), Shared::new(bag), Shared::new(visuals));
    let started = Instant::now();
    let fatal_guard = crate::sim::fatal::during_run(fatal_finisher(
        &folder,
        &manifest,
        started,
        [recorder.finisher(), bag.finisher(), visuals.finisher()],
    ));
    let cpu_started = crate::cpu_time::thread_cpu_ns();
    let plan = LoopPlan { steps: total_steps, record_every_n_steps: config.recording.every_n_steps.max(1) };
    let mut totals = Totals::default();
    let mut interrupt = Every::new(crate::interrupt::CHECK_EVERY_N_STEPS, InterruptPoll);
    let mut progress = Every::new(1024, Progress::new(options.progress, total_steps, options.on_progress.clone()));
    let outcome = {
        let mut observers: Vec<&mut dyn Observer<RunError>> = vec![&mut totals];
        if let Some(t) = tracking.as_mut() {
            observers.push(t);
        }
        let (mut recorder, mut bag, mut visuals) = (recorder.observer(), bag.observer(), visuals.observer());
        if let Some(r) = recorder.as_mut() {
            observers.push(r);
        }
        if let Some(b) = bag.as_mut() {
            observers.push(b);
        }
        if let Some(v) = visuals.as_mut() {
            observers.push(v);
        }
        let mut live = bridge.as_mut().map(|b| Live(&mut **b));
        if let Some(b) = live.as_mut() {
            observers.push(b);
        }
        observers.push(&mut interrupt);
        observers.push(&mut progress);
        sim.run(plan, &mut observers)
    };
    drop(fatal_guard);
    let (recorder, bag, visuals) = (recorder.take(), bag.take(), visuals.take());
    let visuals_done = visuals.map_or(Ok(()), |v| v.finish().map(|_| ()));
    let outcome = outcome.and_then(|()| visuals_done.map_err(RunError::from)).map(|()| {
        let simulated_secs = sim.world().time_secs();
        let d = totals.0.displacement();
        let per_sec = |x: f64| if simulated_secs > 0.0 { x / simulated_secs } else { 0.0 };
        RunSummary {
            run_folder: folder.clone(),
            simulated_secs,
            distance_m: d.distance_m,
            mean_speed_m_per_s: per_sec(d.distance_m),
            heading_deg: d.heading_deg,
            forward_speed_m_per_s: per_sec(d.forward_m),
            peak_contact_force_10ms_n: sim.contact_peaks().peak_windowed_n,
            contact_force_window_secs: sim.contact_peaks().window_secs(),
            peak_contact_force_step_n: sim.contact_peaks().peak_step_n,
            max_penetration_m: totals.0.max_penetration_m,
            actuator_energy_j: totals.0.actuator_energy_j,
            obstacle_contact_secs: totals.0.obstacle_contact_secs,
            start_sink_m: sim.world().start_sink_m(),
            tracking: tracking.as_ref().and_then(|t| t.totals.report(&t.joint_names)),
            notes: setup_notes(config, options, sim.world()),
            steps_per_wall_sec: 0.0,
            real_time_factor: 0.0,
            loop_cpu_secs: 0.0,
        }
    });
    let wall = started.elapsed().as_secs_f64();
    let loop_cpu_secs = crate::cpu_time::thread_cpu_ns().saturating_sub(cpu_started) as f64 * 1e-9;
    manifest.wall_time_secs = wall;
    manifest.steps = sim.steps();
    manifest.simulated_secs = sim.world().time_secs();
    manifest.mujoco_warnings = sim.world().warning_counts();
    manifest.ros2 = bridge.as_ref().map(|b| b.report());
    // Every table is closed and listed with the whole rows it holds, also after a failure.
    let (mut tables, mut tables_done) = match recorder {
        Some(r) => r.finish(),
        None => (Vec::new(), Ok(())),
    };
    if let Some(b) = bag {
        let (files, done) = b.finish();
        tables.extend(files);
        tables_done = tables_done.and(done);
    }
    manifest.tables = tables;
    let result = match (outcome, tables_done) {
        (Ok(summary), Ok(())) => Ok(summary),
        (Err(e), Ok(())) => Err(e),
        (Err(e), Err(t)) => {
            // Both failed (say, diverged on a full disk): the run's error leads, the table's is logged.
            log::error!("{t}");
            Err(e)
        }
        (Ok(_), Err(e)) => Err(RunError::from(e)),
    };
    let mut summary = match result {
        Ok(summary) => summary,
        Err(e) => return Err(end_unfinished(&folder, &mut manifest, &mut reserve, e)),
    };
    summary.steps_per_wall_sec = sim.steps() as f64 / wall.max(1e-9);
    summary.real_time_factor = sim.world().time_secs() / wall.max(1e-9);
    summary.loop_cpu_secs = loop_cpu_secs;
    manifest.status = RunStatus::Complete;
    manifest.summary = Some(summary.clone());
    reserve.release();
    manifest.write(&folder)?;
    if config.general.plot {
        // The run is complete (and its manifest says so) whatever happens to the plots; the
        // manifest's `plots` says how plotting ended.
        let plotted = crate::plot::plot_run_folder(&folder);
        manifest.plots = Some(match &plotted {
            Ok(_) => "written".to_string(),
            Err(crate::plot::PlotError::Interrupted { .. }) => "interrupted".to_string(),
            Err(e) => format!("failed: {e}"),
        });
        if let Err(m) = manifest.write(&folder) {
            log::error!("{m}");
        }
        plotted?;
    }
    Ok(summary)
}

/// Makes a new run folder a run folder: first the space kept for its last manifest
/// ([`SpaceReserve`]), then the start manifest (`incomplete`). A run folder that this function
/// returns holds a manifest; if it cannot (a full disk), a folder the run `created` is removed
/// again, and the error returned.
fn open_run_folder(folder: &Path, created: bool, manifest: &mut Manifest) -> Result<SpaceReserve, RecordError> {
    let remove = || {
        if created {
            let _ = std::fs::remove_dir_all(folder);
        }
    };
    let mut reserve = SpaceReserve::create(folder, manifest.to_text().len()).inspect_err(|_| remove())?;
    if let Err(e) = manifest.write(folder) {
        // Try once more with the reserved space, to leave a manifest that says why.
        reserve.release();
        manifest.status = RunStatus::Failed;
        manifest.error = Some(e.to_string());
        if manifest.write(folder).is_err() {
            remove();
        }
        return Err(e);
    }
    Ok(reserve)
}

/// The files of the run folder besides the tables: `config.toml`, `model.xml`, included and
/// copied terrain files.
fn write_run_files(config: &Config, folder: &Path, world: &World) -> Result<(), RunError> {
    let write = |name: &str, text: &str| -> Result<(), RecordError> {
        let path = folder.join(name);
        std::fs::write(&path, text).map_err(record::io_err(&path))
    };
    write("config.toml", &run_folder_config(config, &world.copied_files).to_toml_string())?;
    write("model.xml", &world.mjcf)?;
    for (name, text) in &world.included_files {
        write(name, text)?;
    }
    for c in &world.copied_files {
        crate::sim::copy_file(folder, c)?;
    }
    Ok(())
}

/// Ends a run that did not complete: frees the reserved space and writes the manifest that says
/// so (`incomplete` after a signal, else `failed`, with the error). The run's error matters more
/// than a manifest that cannot be written (say, on the same full disk): that one is logged.
fn end_unfinished(folder: &Path, manifest: &mut Manifest, reserve: &mut SpaceReserve, e: RunError) -> RunError {
    reserve.release();
    // A stop from outside (a signal, a lockstep peer that went away) leaves an incomplete run
    // with readable tables, not a failed one.
    let stopped = matches!(
        e,
        RunError::Interrupted { .. }
            | RunError::Ros2(crate::ros2::Ros2Error::PeerTimeout { .. } | crate::ros2::Ros2Error::NoPeer { .. })
    );
    manifest.status = if stopped { RunStatus::Incomplete } else { RunStatus::Failed };
    manifest.error = Some(e.to_string());
    if let Err(m) = manifest.write(folder) {
        log::error!("{m}");
    }
    e
}

/// The config as recorded in the run folder: its terrain file keys point at the copies in the
/// run folder (paths relative to `config.toml`, which is how a config file's paths are read),
/// so `simserpent run <run folder>/config.toml` rebuilds the same scene from the folder alone.
fn run_folder_config(config: &Config, copies: &[crate::model::features::FileCopy]) -> Config {
    let mut c = config.clone();
    for copy in copies {
        let source = copy.source.display().to_string();
        let t = &mut c.terrain;
        let fields = [&mut t.heightfield.file, &mut t.mesh_terrain.file, &mut t.include_mjcf]
            .into_iter()
            .chain(t.mesh_obstacles.iter_mut().map(|m| &mut m.file));
        for field in fields {
            if *field == source {
                field.clone_from(&copy.dest);
            }
        }
    }
    c
}

/// A part of a run (tables, bag, visuals) that both the step loop and the finisher of a fatal
/// MuJoCo error ([`fatal_finisher`]) reach: the step loop borrows it only while it calls it, so
/// an error raised inside MuJoCo's step finds it free.
struct Shared<T>(Rc<RefCell<Option<T>>>);

/// Closes a part of a run after a fatal MuJoCo error; returns the tables it lists.
type PartFinisher = Box<dyn FnOnce() -> Vec<(String, u64)>>;

/// A part of a run that ends by closing its files.
trait EndPart {
    /// Closes the files; returns the tables for the manifest.
    fn end(self) -> Vec<(String, u64)>;
}

impl EndPart for Recorder {
    fn end(self) -> Vec<(String, u64)> {
        self.finish().0
    }
}

impl EndPart for crate::ros2::BagRecorder {
    fn end(self) -> Vec<(String, u64)> {
        self.finish().0
    }
}

impl EndPart for crate::render::RunVisuals {
    fn end(self) -> Vec<(String, u64)> {
        let _ = self.finish();
        Vec::new()
    }
}

impl<T: EndPart + 'static> Shared<T> {
    fn new(part: Option<T>) -> Self {
        Self(Rc::new(RefCell::new(part)))
    }

    /// The step loop's observer of the part, if there is one.
    fn observer(&self) -> Option<SharedObserver<T>> {
        self.0.borrow().is_some().then(|| SharedObserver(Rc::clone(&self.0)))
    }

    /// The part, back for the normal end of the run.
    fn take(&self) -> Option<T> {
        self.0.borrow_mut().take()
    }

    /// Closes the part from the fatal error's finisher (nothing when the step loop holds it).
    fn finisher(&self) -> PartFinisher {
        let part = Rc::clone(&self.0);
        Box::new(move || part.try_borrow_mut().ok().and_then(|mut p| p.take()).map_or_else(Vec::new, EndPart::end))
    }
}

/// See [`Shared::observer`].
struct SharedObserver<T>(Rc<RefCell<Option<T>>>);

impl<T: Observer<RunError>> Observer<RunError> for SharedObserver<T> {
    fn on_start(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        self.0.borrow_mut().as_mut().map_or(Ok(()), |p| p.on_start(view))
    }
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        self.0.borrow_mut().as_mut().map_or(Ok(()), |p| p.on_step(view))
    }
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), RunError> {
        self.0.borrow_mut().as_mut().map_or(Ok(()), |p| p.on_record(view, snapshot))
    }
    fn on_end(&mut self, view: &StepView<'_>, completed: bool) -> Result<(), RunError> {
        self.0.borrow_mut().as_mut().map_or(Ok(()), |p| p.on_end(view, completed))
    }
}

/// Ends a run that a fatal MuJoCo error stops (`sim::fatal`), as a divergence ends it: every
/// part's files closed with the rows of the last recorded instant (the same instant in every
/// table: the step loop hands each recorded instant to all of them before it steps), the
/// manifest `failed` with the error, the step and its simulated time.
fn fatal_finisher(
    folder: &Path,
    manifest: &Manifest,
    started: Instant,
    parts: [PartFinisher; 3],
) -> crate::sim::fatal::RunFinisher {
    let (folder, mut manifest) = (folder.to_path_buf(), manifest.clone());
    Box::new(move |text| {
        let (step, time_secs) = crate::sim::fatal::position();
        let error = crate::sim::fatal::run_error(text, time_secs, step);
        manifest.tables = parts.into_iter().flat_map(|finish| finish()).collect();
        manifest.status = RunStatus::Failed;
        manifest.error = Some(error.clone());
        manifest.steps = step;
        manifest.simulated_secs = time_secs;
        manifest.wall_time_secs = started.elapsed().as_secs_f64();
        // The space kept for this manifest (its guard's destructor does not run).
        let _ = std::fs::remove_file(folder.join(SpaceReserve::FILE));
        match manifest.write(&folder) {
            Ok(()) => format!(
                "{error}; the run folder {} holds every table up to the last recorded instant (manifest `failed`)",
                folder.display()
            ),
            Err(e) => format!("{error}; {e}"),
        }
    })
}

/// The run summary's physics, added up over the recorded instants.
#[derive(Default)]
struct Totals(RunTotals);

impl Observer<RunError> for Totals {
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), RunError> {
        // Each recorded instant's power holds until the next recorded one (or the end).
        let every = view.plan.record_every_n_steps;
        let held_steps = ((view.k / every + 1) * every).min(view.plan.steps) - view.k;
        self.0.add(snapshot, view.world.timestep_secs(), held_steps);
        Ok(())
    }
}

impl Observer<RunError> for Recorder {
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), RunError> {
        Ok(self.write(view.k, snapshot)?)
    }
}

impl Observer<RunError> for crate::ros2::BagRecorder {
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), RunError> {
        Ok(self.write(snapshot, view.command)?)
    }
}

/// The live ROS 2 bridge as one of the run's observers (its errors are [`crate::ros2::Ros2Error`]s).
struct Live<'a>(&'a mut dyn crate::ros2::LiveBridge);

impl Observer<RunError> for Live<'_> {
    fn on_start(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        Ok(self.0.on_start(view)?)
    }
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), RunError> {
        Ok(self.0.on_record(view, snapshot)?)
    }
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        Ok(self.0.on_step(view)?)
    }
    fn on_end(&mut self, view: &StepView<'_>, completed: bool) -> Result<(), RunError> {
        Ok(self.0.on_end(view, completed)?)
    }
}

impl Observer<RunError> for crate::render::RunVisuals {
    fn on_record(&mut self, view: &StepView<'_>, _snapshot: &Snapshot) -> Result<(), RunError> {
        Ok(self.on_recorded_step(view.world.data())?)
    }
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        Ok(self.on_step(view.world.data(), view.world.timestep_secs())?)
    }
}

/// The joints' tracking of their commanded angles: at every instant, the angle commanded (the
/// open-loop gait's target; a closed-loop controller's position set-point) against the joint's
/// actual angle (no allocation per step: the buffers are sized once).
struct Tracking {
    /// The open-loop gait; `None`: the position set-points of the command are the targets.
    trajectory: Option<Box<dyn crate::control::JointTrajectory>>,
    target_rad: Vec<f64>,
    target_velocity_rad_per_s: Vec<f64>,
    actual_rad: Vec<f64>,
    qpos_adr: Vec<usize>,
    joint_names: Vec<String>,
    totals: crate::state::TrackingTotals,
}

impl Tracking {
    /// `None` without joints, without a moving gait (open loop), or for a closed-loop controller
    /// that does not drive position servos (its set-points are not in the command).
    fn new(config: &Config, world: &World) -> Option<Self> {
        use crate::config::{ControlMethod, ControllerKind, GaitKind};
        let n = world.n_joints();
        let trajectory = match crate::control::effective_controller(config) {
            ControllerKind::Gait if config.gait.kind != GaitKind::None => {
                Some(crate::control::trajectory_from_config(config))
            }
            ControllerKind::Gait => return None,
            _ if config.control.method == ControlMethod::Position => None,
            _ => return None,
        };
        if n == 0 {
            return None;
        }
        Some(Self {
            trajectory,
            target_rad: vec![0.0; n],
            target_velocity_rad_per_s: vec![0.0; n],
            actual_rad: vec![0.0; n],
            qpos_adr: world.index.joints.iter().map(|j| j.qpos_adr).collect(),
            joint_names: world.index.joints.iter().map(|j| j.name.clone()).collect(),
            totals: crate::state::TrackingTotals::new(n, config.gait.ramp_secs),
        })
    }
}

impl Observer<RunError> for Tracking {
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        let t = view.time_secs();
        match &self.trajectory {
            Some(trajectory) => trajectory.targets(t, &mut self.target_rad, &mut self.target_velocity_rad_per_s),
            None => self.target_rad.copy_from_slice(&view.command.position_rad),
        }
        let qpos = view.world.data().qpos();
        for (x, &adr) in self.actual_rad.iter_mut().zip(&self.qpos_adr) {
            *x = qpos[adr];
        }
        self.totals.add(t, &self.target_rad, &self.actual_rad);
        Ok(())
    }
}

/// Stops the run when SIGINT/SIGTERM arrived (one relaxed atomic load; used every
/// [`crate::interrupt::CHECK_EVERY_N_STEPS`] steps).
struct InterruptPoll;

impl Observer<RunError> for InterruptPoll {
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        if !view.is_last() && crate::interrupt::requested() {
            return Err(RunError::Interrupted { time_secs: view.time_secs(), step: view.k });
        }
        Ok(())
    }
}

/// A progress bar that appears only after two seconds and only on a terminal, and the caller's
/// callback.
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    started: Instant,
    total: u64,
    shown: std::cell::Cell<bool>,
    callback: Option<ProgressCallback>,
}

impl Progress {
    fn new(enabled: bool, total: u64, callback: Option<ProgressCallback>) -> Self {
        let bar = (enabled && std::io::stderr().is_terminal()).then(|| {
            let bar = indicatif::ProgressBar::with_draw_target(Some(total), indicatif::ProgressDrawTarget::hidden());
            if let Ok(style) =
                indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% {pos}/{len} steps, ETA {eta}")
            {
                bar.set_style(style);
            }
            bar
        });
        Self { bar, started: Instant::now(), total, shown: std::cell::Cell::new(false), callback }
    }

    fn tick(&self, step: u64) {
        if let Some(c) = &self.callback {
            c.report(step.min(self.total), self.total);
        }
        if let Some(bar) = &self.bar {
            if !self.shown.get() && self.started.elapsed() > Duration::from_secs(2) {
                bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                self.shown.set(true);
            }
            bar.set_position(step.min(self.total));
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Observer<RunError> for Progress {
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), RunError> {
        self.tick(view.k);
        Ok(())
    }
    fn on_end(&mut self, view: &StepView<'_>, _completed: bool) -> Result<(), RunError> {
        if let Some(c) = &self.callback {
            c.report(view.k.min(self.total), self.total);
        }
        self.finish();
        Ok(())
    }
}

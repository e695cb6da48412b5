//! `simserpent study accuracy`: the cheapest physics that is still right.
//!
//! Every scenario (the default job, cases of the undulation experiment, an impact) is run with
//! RK4 at 0.1 ms as the reference, and with RK4, implicitfast and Euler at 0.25, 0.5, 1, 2, 5
//! and 10 ms. For each combination the study measures the error of the quantities a user reads
//! off a run, against the reference:
//!
//! | quantity | error |
//! |---|---|
//! | centre-of-mass path | distance between the final centres of mass / the reference's path length (%) |
//! | mean forward speed | relative (%), centre of mass along the start heading (+x) over the run |
//! | heading | final heading of the head, absolute (deg) |
//! | joint angles | RMS over a 10 ms grid and all joints / RMS of the reference's angles (%) |
//! | peak contact force | relative (%), largest single contact normal force of the run |
//! | mean contact force | relative (%), time mean of the total contact normal force |
//! | penetration | relative (%), deepest penetration of the run |
//!
//! and its cost: steps per wall second and simulated seconds per wall second (a separate run
//! with recording off, one at a time). With `physics.floor_friction = "stick_slip"` the stick time
//! constant must be at least 5 steps; at longer steps the study raises it to 5 steps (what a
//! user must do) and notes it in the row. A combination that the config rejects (e.g. a contact
//! time constant shorter than 2 steps) is reported as *invalid* with the reason; one that
//! blows up as *diverged* with SimSerpent's divergence message. Neither is hidden.

use crate::config::{AutoSecs, Config, ConfigError, FloorFriction, Integrator};
use crate::plot::{self, PointSeries};
use crate::sim::{LoopPlan, Observer, SimError, Simulation, Snapshot, StepView, World};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The reference: RK4 at this step (s).
pub const REFERENCE_TIMESTEP_SECS: f64 = 1e-4;
/// The steps compared (s).
pub const TIMESTEPS_SECS: [f64; 6] = [0.00025, 0.0005, 0.001, 0.002, 0.005, 0.01];
/// The integrators compared.
pub const INTEGRATORS: [Integrator; 3] = [Integrator::RK4, Integrator::ImplicitFast, Integrator::Euler];
/// Sample period of the joint-angle and path comparison (s): a multiple of every step.
const SAMPLE_SECS: f64 = 0.01;
/// The bound the issue sets for "the same answers".
pub const SAME_ANSWER_PERCENT: f64 = 2.0;
/// A heading error counts as within 2 % when it is at most 2 % of a right angle (deg).
pub const HEADING_BOUND_DEG: f64 = 1.8;

/// Errors of the study.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StudyError {
    /// The reference run of a scenario failed: no comparison is possible.
    #[error("scenario {scenario}: the reference run (RK4, 0.1 ms) failed: {message}")]
    Reference {
        /// The scenario.
        scenario: String,
        /// Why.
        message: String,
    },
    /// A file could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] plot::PlotError),
    /// The worker threads could not be started.
    #[error("cannot start {threads} worker threads: {message}")]
    Threads {
        /// Threads asked for.
        threads: usize,
        /// Why.
        message: String,
    },
}

/// One situation the integrators are compared on.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Short name (table rows, file names).
    pub name: String,
    /// The config (its integrator and timestep are replaced per combination).
    pub config: Config,
    /// Initial velocity along x or y of the free joint (m/s), for an impact.
    pub launch: Option<(usize, f64)>,
}

/// The scenarios: the default job (10 s), two cases of the undulation experiment (isotropic
/// Coulomb friction 0.5 and anisotropic friction ratio 10, 10 s each) and the 10-link impact of
/// the collision experiment (0.5 s), all on top of `base` (the user's config: e.g.
/// `physics.floor_friction`). `quick` shortens every run to 2 s (the impact stays 0.5 s).
pub fn scenarios(base: &Config, quick: bool) -> Vec<Scenario> {
    let secs = if quick { 2.0 } else { 10.0 };
    let mut default_job = base.clone();
    default_job.general.duration_secs = secs;
    let mut out = vec![Scenario { name: "default job".into(), config: default_job, launch: None }];
    for (name, config) in crate::experiments::undulation_study_cases(base) {
        let mut config = config;
        config.general.duration_secs = secs;
        out.push(Scenario { name, config, launch: None });
    }
    let (config, axis, speed) = crate::experiments::impact_study_case(base);
    out.push(Scenario { name: "impact (10 links along x)".into(), config, launch: Some((axis, speed)) });
    out
}

/// What one run measured.
#[derive(Debug, Clone, Default)]
struct Trace {
    /// Centre of mass (x, y) on the sample grid (m).
    com_xy: Vec<[f64; 2]>,
    /// Joint angles on the sample grid (rad).
    joints: Vec<Vec<f64>>,
    /// Heading of the head at the end (rad).
    heading_end_rad: f64,
    /// Largest single contact normal force (N).
    peak_force_n: f64,
    /// Sum over recorded instants of the total contact normal force (N), and their count.
    force_sum_n: f64,
    instants: u64,
    /// Deepest penetration (m).
    penetration_m: f64,
    /// Steps between samples.
    sample_every: u64,
}

impl Observer<SimError> for Trace {
    fn on_record(&mut self, view: &StepView<'_>, s: &Snapshot) -> Result<(), SimError> {
        let (mut total, mut peak, mut deepest) = (0.0f64, 0.0f64, 0.0f64);
        for c in &s.contacts {
            total += c.normal_force_n.max(0.0);
            peak = peak.max(c.normal_force_n);
            deepest = deepest.max(-c.distance_m);
        }
        self.force_sum_n += total;
        self.instants += 1;
        self.peak_force_n = self.peak_force_n.max(peak);
        self.penetration_m = self.penetration_m.max(deepest);
        if view.k.is_multiple_of(self.sample_every) {
            let com = s.centre_of_mass_m();
            self.com_xy.push([com[0], com[1]]);
            self.joints.push(s.joint_angle_rad.clone());
        }
        if view.is_last() {
            let h = crate::state::heading_xy(s.link_quat[0]);
            self.heading_end_rad = h[1].atan2(h[0]);
        }
        Ok(())
    }
}

/// The result of one combination.
#[derive(Debug, Clone)]
pub enum Outcome {
    /// Ran to the end.
    Done(Measured),
    /// The config is rejected at this step (the reason).
    Invalid(String),
    /// The run blew up (SimSerpent's divergence message).
    Diverged(String),
}

/// Errors and cost of one combination that ran.
#[derive(Debug, Clone, Copy, Default)]
pub struct Measured {
    /// Centre-of-mass end point error / reference path length (%).
    pub com_path_percent: f64,
    /// Mean forward speed, relative error (%).
    pub forward_speed_percent: f64,
    /// Heading at the end, absolute error (deg).
    pub heading_deg: f64,
    /// Joint-angle RMS error / RMS of the reference's joint angles (%).
    pub joint_rms_percent: f64,
    /// Peak contact force, relative error (%).
    pub peak_force_percent: f64,
    /// Mean contact force, relative error (%).
    pub mean_force_percent: f64,
    /// Deepest penetration, relative error (%).
    pub penetration_percent: f64,
    /// Mean forward speed of this run (m/s).
    pub forward_speed_m_per_s: f64,
    /// Steps per wall second (recording off).
    pub steps_per_sec: f64,
    /// Simulated seconds per wall second (recording off).
    pub real_time_factor: f64,
}

impl Measured {
    /// The largest relative error (%), the heading counted as a share of [`HEADING_BOUND_DEG`]
    /// scaled to [`SAME_ANSWER_PERCENT`].
    pub fn worst_percent(&self) -> f64 {
        [
            self.com_path_percent,
            self.forward_speed_percent,
            self.heading_deg / HEADING_BOUND_DEG * SAME_ANSWER_PERCENT,
            self.joint_rms_percent,
            self.peak_force_percent,
            self.mean_force_percent,
            self.penetration_percent,
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }
}

/// One row of the study.
#[derive(Debug, Clone)]
pub struct Row {
    /// Scenario name.
    pub scenario: String,
    /// Integrator.
    pub integrator: Integrator,
    /// Step (s).
    pub timestep_secs: f64,
    /// What happened.
    pub outcome: Outcome,
    /// A setting the study had to change for this step (the stick time constant), if any.
    pub note: Option<String>,
}

/// The scenario's config at this integrator and step. With `physics.floor_friction =
/// "stick_slip"`, a stick time constant below its stability bound of 5 steps is raised to 5
/// steps (what a user must do at that step); the second value says so.
fn with_step(scenario: &Scenario, integrator: Integrator, dt: f64) -> Result<(Config, Option<String>), ConfigError> {
    let mut c = scenario.config.clone();
    c.general.integrator = integrator;
    c.general.timestep_secs = dt;
    c.recording.enabled = false;
    let mut note = None;
    if c.physics.floor_friction == FloorFriction::StickSlip {
        match c.physics.floor_stick_time_constant_secs {
            AutoSecs::Secs(tau) if tau < 5.0 * dt => {
                c.physics.floor_stick_time_constant_secs = AutoSecs::Secs(5.0 * dt);
                note = Some(format!("stick τ {} ms", 5.0 * dt * 1e3));
            }
            // "auto" is max(5 ms, 5 steps): say when the step made it longer than 5 ms.
            AutoSecs::Auto if 5.0 * dt > 0.005 => note = Some(format!("stick τ auto = {} ms", 5.0 * dt * 1e3)),
            _ => {}
        }
    }
    c.validate()?;
    Ok((c, note))
}

fn build(config: &Config, launch: Option<(usize, f64)>) -> Result<Simulation, SimError> {
    let mut world = World::from_config(config)?;
    if let Some((axis, speed)) = launch {
        world.qvel_mut()[axis] = speed;
    }
    world.forward();
    Ok(Simulation::new(config, world))
}

fn steps_of(config: &Config) -> u64 {
    (config.general.duration_secs / config.general.timestep_secs).round() as u64
}

/// Runs one combination with every instant read out. `Err` is the outcome that is not a trace.
fn trace(scenario: &Scenario, integrator: Integrator, dt: f64) -> Result<Trace, Outcome> {
    let (config, _) = with_step(scenario, integrator, dt).map_err(|e| Outcome::Invalid(e.to_string()))?;
    let mut sim = build(&config, scenario.launch).map_err(|e| Outcome::Invalid(e.to_string()))?;
    let mut t = Trace { sample_every: (SAMPLE_SECS / dt).round().max(1.0) as u64, ..Trace::default() };
    let plan = LoopPlan { steps: steps_of(&config), record_every_n_steps: 1 };
    sim.run::<SimError>(plan, &mut [&mut t]).map_err(|e| Outcome::Diverged(e.to_string()))?;
    Ok(t)
}

/// Steps per wall second of one combination with recording off.
fn cost(scenario: &Scenario, integrator: Integrator, dt: f64) -> Result<f64, SimError> {
    let (config, _) = with_step(scenario, integrator, dt)?;
    let mut sim = build(&config, scenario.launch)?;
    let plan = LoopPlan { steps: steps_of(&config), record_every_n_steps: 0 };
    let start = Instant::now();
    sim.run::<SimError>(plan, &mut [])?;
    Ok(plan.steps as f64 / start.elapsed().as_secs_f64())
}

fn relative_percent(x: f64, reference: f64) -> f64 {
    if reference.abs() < 1e-12 {
        if x.abs() < 1e-12 { 0.0 } else { f64::INFINITY }
    } else {
        100.0 * ((x - reference) / reference).abs()
    }
}

fn forward_speed(t: &Trace, duration_secs: f64) -> f64 {
    match (t.com_xy.first(), t.com_xy.last()) {
        (Some(a), Some(b)) => (b[0] - a[0]) / duration_secs,
        _ => 0.0,
    }
}

fn compare(t: &Trace, r: &Trace, duration_secs: f64) -> Measured {
    let path_len: f64 = r.com_xy.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum();
    let end_error = match (t.com_xy.last(), r.com_xy.last()) {
        (Some(a), Some(b)) => (a[0] - b[0]).hypot(a[1] - b[1]),
        _ => f64::INFINITY,
    };
    let (mut sq_err, mut sq_ref, mut n) = (0.0, 0.0, 0usize);
    for (a, b) in t.joints.iter().zip(&r.joints) {
        for (x, y) in a.iter().zip(b) {
            sq_err += (x - y) * (x - y);
            sq_ref += y * y;
            n += 1;
        }
    }
    let joint_rms_percent = if n == 0 || sq_ref == 0.0 {
        if sq_err == 0.0 { 0.0 } else { f64::INFINITY }
    } else {
        100.0 * (sq_err / sq_ref).sqrt()
    };
    let mut dh = (t.heading_end_rad - r.heading_end_rad).to_degrees().abs() % 360.0;
    if dh > 180.0 {
        dh = 360.0 - dh;
    }
    let mean = |x: &Trace| x.force_sum_n / x.instants.max(1) as f64;
    let v = forward_speed(t, duration_secs);
    Measured {
        com_path_percent: if path_len > 0.0 { 100.0 * end_error / path_len } else { f64::INFINITY },
        forward_speed_percent: relative_percent(v, forward_speed(r, duration_secs)),
        heading_deg: dh,
        joint_rms_percent,
        peak_force_percent: relative_percent(t.peak_force_n, r.peak_force_n),
        mean_force_percent: relative_percent(mean(t), mean(r)),
        penetration_percent: relative_percent(t.penetration_m, r.penetration_m),
        forward_speed_m_per_s: v,
        steps_per_sec: 0.0,
        real_time_factor: 0.0,
    }
}

/// The whole study: every scenario × integrator × step, the accuracy runs in parallel on
/// `threads` threads (0: all cores), then the cost runs one at a time. `progress`: a line per
/// finished scenario on stderr.
pub fn run_study(scenarios: &[Scenario], threads: usize, progress: bool) -> Result<Vec<Row>, StudyError> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| StudyError::Threads { threads, message: e.to_string() })?;
    let combos: Vec<(Integrator, f64)> =
        INTEGRATORS.iter().flat_map(|&i| TIMESTEPS_SECS.iter().map(move |&dt| (i, dt))).collect();
    let mut rows = Vec::new();
    for scenario in scenarios {
        let start = Instant::now();
        let duration = scenario.config.general.duration_secs;
        // Reference first in the same parallel batch as the others.
        let mut jobs = vec![(Integrator::RK4, REFERENCE_TIMESTEP_SECS)];
        jobs.extend(combos.iter().copied());
        let traces: Vec<Result<Trace, Outcome>> =
            pool.install(|| jobs.par_iter().map(|&(i, dt)| trace(scenario, i, dt)).collect());
        let reference = match &traces[0] {
            Ok(t) => t.clone(),
            Err(Outcome::Invalid(m) | Outcome::Diverged(m)) => {
                return Err(StudyError::Reference { scenario: scenario.name.clone(), message: m.clone() });
            }
            Err(Outcome::Done(_)) => unreachable!("a failed trace is never Done"),
        };
        for (&(integrator, dt), t) in combos.iter().zip(&traces[1..]) {
            let outcome = match t {
                Ok(t) => {
                    let mut m = compare(t, &reference, duration);
                    match cost(scenario, integrator, dt) {
                        Ok(steps_per_sec) => {
                            m.steps_per_sec = steps_per_sec;
                            m.real_time_factor = steps_per_sec * dt;
                            Outcome::Done(m)
                        }
                        Err(e) => Outcome::Diverged(e.to_string()),
                    }
                }
                Err(o) => o.clone(),
            };
            let note = with_step(scenario, integrator, dt).ok().and_then(|(_, note)| note);
            rows.push(Row { scenario: scenario.name.clone(), integrator, timestep_secs: dt, outcome, note });
        }
        if progress {
            eprintln!("study accuracy: scenario {} done in {:.1} s", scenario.name, start.elapsed().as_secs_f64());
        }
    }
    Ok(rows)
}

fn integrator_name(i: Integrator) -> &'static str {
    i.mjcf_name()
}

fn pct(x: f64) -> String {
    if x.is_finite() { format!("{x:.2}") } else { "∞".into() }
}

/// The study's table (Markdown), one row per scenario, integrator and step.
pub fn to_markdown(rows: &[Row]) -> String {
    let mut out = String::from(
        "| scenario | integrator | step (ms) | CoM path (%) | forward speed (%) | heading (deg) | joint RMS (%) | \
         peak force (%) | mean force (%) | penetration (%) | worst (%) | steps/s | real-time factor |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let note = r.note.as_ref().map_or(String::new(), |n| format!(" ({n})"));
        let head = format!("| {} | {} | {}{note} |", r.scenario, integrator_name(r.integrator), r.timestep_secs * 1e3);
        let line = match &r.outcome {
            Outcome::Done(m) => format!(
                "{head} {} | {} | {} | {} | {} | {} | {} | {}{} | {:.0} | {:.1} |",
                pct(m.com_path_percent),
                pct(m.forward_speed_percent),
                pct(m.heading_deg),
                pct(m.joint_rms_percent),
                pct(m.peak_force_percent),
                pct(m.mean_force_percent),
                pct(m.penetration_percent),
                pct(m.worst_percent()),
                if m.worst_percent() <= SAME_ANSWER_PERCENT { " ✓" } else { "" },
                m.steps_per_sec,
                m.real_time_factor
            ),
            Outcome::Invalid(why) => {
                format!("{head} invalid: {} | | | | | | | | | |", why.replace('|', "/").replace('\n', " "))
            }
            Outcome::Diverged(why) => {
                format!("{head} **diverged**: {} | | | | | | | | | |", why.replace('|', "/").replace('\n', " "))
            }
        };
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// Writes `accuracy.md` (the table) and the work-precision plots (`work_precision_<n>.png` and
/// `.svg`, one per scenario: real-time factor against the worst error, a line per integrator)
/// into `dir`. Returns the files written.
pub fn write_outputs(dir: &Path, rows: &[Row], header: &str) -> Result<Vec<PathBuf>, StudyError> {
    std::fs::create_dir_all(dir).map_err(|source| StudyError::Write { path: dir.to_path_buf(), source })?;
    let table = dir.join("accuracy.md");
    let text = format!("{header}\n\n{}", to_markdown(rows));
    std::fs::write(&table, text).map_err(|source| StudyError::Write { path: table.clone(), source })?;
    let mut files = vec![table];
    let mut scenarios: Vec<&str> = Vec::new();
    for r in rows {
        if !scenarios.contains(&r.scenario.as_str()) {
            scenarios.push(&r.scenario);
        }
    }
    for (n, scenario) in scenarios.iter().enumerate() {
        let series: Vec<PointSeries> = INTEGRATORS
            .iter()
            .map(|&i| PointSeries {
                name: integrator_name(i).to_string(),
                points: rows
                    .iter()
                    .filter(|r| r.scenario == *scenario && r.integrator == i)
                    .filter_map(|r| match &r.outcome {
                        Outcome::Done(m) => Some((m.real_time_factor, m.worst_percent().max(1e-3))),
                        _ => None,
                    })
                    .collect(),
            })
            .collect();
        files.extend(plot::plot_log_log(
            dir,
            &format!("work_precision_{n}"),
            &format!("work-precision: {scenario}"),
            "simulated seconds per wall second",
            "largest error against RK4 0.1 ms (%)",
            &series,
        )?);
    }
    Ok(files)
}

//! `simserpent study accuracy`: the cheapest physics that is still right.
//!
//! Every case is run with every [`Setting`] (integrator × timestep) and with the reference
//! (RK4 at 0.1 ms), and compared with the reference:
//!
//! | quantity | error |
//! |---|---|
//! | centre-of-mass path | distance between the centres of mass at the end (10 s) / the reference's net displacement |
//! | mean forward speed | relative error of the mean speed of the centre of mass along the starting direction (after the ramp-in) |
//! | heading | angle between the directions of travel (after the ramp-in), in rad: a heading error θ puts the end point θ × distance sideways, so 0.02 rad counts as 2 % |
//! | joint angles | RMS over time (10 ms samples) and joints of (q − q_ref) / RMS of q_ref |
//! | peak contact force | relative error of the largest contact normal force of the run (every step): the instantaneous peak, which depends on where the steps sample a transient |
//! | peak force, 10 ms | relative error of the largest force a force sensor with a 10 ms averaging window would read: per link, the total contact force vector averaged over consecutive 10 ms windows (aligned to t = 0, the same windows at every step size), its magnitude, the largest over links and windows. The impulse per 10 ms: insensitive to when a step samples a short transient |
//! | mean contact force | relative error of the time average of the largest contact normal force at each step |
//! | penetration | relative error of the largest penetration of the run (every step) |
//! | rebound speed (impacts) | relative error of the largest speed of the centre of mass away from the surface after the impact |
//!
//! A quantity that does not apply to a case (no joints, no travel) is left out ("-").
//! The worst of a row's errors decides whether a setting "gives the same answers" (≤ 2 %); the
//! report also gives the cheapest setting with the instantaneous peak left out, and the cheapest
//! within 5 % on the motion quantities alone (path, speed, heading, joint angles: the RL preset).
//!
//! Cost is measured in a second, unrecorded run of each setting (recording off: only the step
//! loop, controller and ground model): steps per wall second and simulated seconds per wall
//! second. Runs that diverge (NaN/inf, MuJoCo's warnings, runaway energy) or that the config
//! rejects are reported as such, with the error, and take no part in the choice.

use crate::config::{AutoSecs, Config, GroundModel, Integrator, TerrainKind};
use crate::run::RunError;
use crate::sim::{Observer, SimError, Simulation, StepView, World};
use crate::state::Snapshot;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Simulated time between two samples of the paths and joint angles (s): a whole number of
/// steps at every timestep of the study.
pub const SAMPLE_PERIOD_SECS: f64 = 0.01;

/// Averaging window of the sensor-style peak force (s): [`SAMPLE_PERIOD_SECS`], a whole number
/// of steps at every timestep of the study, so every setting averages over the same windows.
pub const FORCE_WINDOW_SECS: f64 = SAMPLE_PERIOD_SECS;

/// The timesteps of the study (s).
pub const TIMESTEPS_SECS: [f64; 6] = [0.000_25, 0.000_5, 0.001, 0.002, 0.005, 0.01];

/// The integrators of the study.
pub const INTEGRATORS: [Integrator; 3] = [Integrator::RK4, Integrator::ImplicitFast, Integrator::Euler];

/// "The same answers": every quantity within 2 % of the reference.
pub const SAME_ANSWERS: f64 = 0.02;

/// The RL preset's tolerance: every quantity within 5 %.
pub const RL_TOLERANCE: f64 = 0.05;

/// An integrator and a timestep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// The integrator.
    pub integrator: Integrator,
    /// The timestep (s).
    pub timestep_secs: f64,
}

impl Setting {
    /// The reference: RK4 at 0.1 ms.
    pub const REFERENCE: Setting = Setting { integrator: Integrator::RK4, timestep_secs: 0.0001 };

    /// "RK4 1 ms".
    pub fn label(&self) -> String {
        format!("{} {} ms", self.integrator.mjcf_name(), self.timestep_secs * 1e3)
    }
}

/// Every setting of the study: [`INTEGRATORS`] × [`TIMESTEPS_SECS`].
pub fn all_settings() -> Vec<Setting> {
    INTEGRATORS
        .iter()
        .flat_map(|&integrator| TIMESTEPS_SECS.iter().map(move |&timestep_secs| Setting { integrator, timestep_secs }))
        .collect()
}

/// What a case measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CaseKind {
    /// A gait: paths, speed, heading and joint angles after `from_secs` (the ramp-in), and the contacts.
    Locomotion {
        /// Start of the measured part (s).
        from_secs: f64,
    },
    /// One body launched at `speed_m_per_s` along world axis `axis` (2: downward).
    Impact {
        /// 0 = +x, 1 = +y, 2 = −z.
        axis: usize,
        /// Launch speed (m/s).
        speed_m_per_s: f64,
    },
}

/// One case of the study.
#[derive(Debug, Clone)]
pub struct Case {
    /// Short name (file names).
    pub name: String,
    /// One line for the report.
    pub description: String,
    /// The config (its integrator and timestep are replaced by each setting's).
    pub config: Config,
    /// What it measures.
    pub kind: CaseKind,
}

/// The sampled outcome of one run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// Sample times (s), every [`SAMPLE_PERIOD_SECS`].
    pub time_secs: Vec<f64>,
    /// Centre of mass (x, y) at each sample (m).
    pub com_m: Vec<[f64; 2]>,
    /// Joint angles at each sample (rad).
    pub joint_angle_rad: Vec<Vec<f64>>,
    /// Unit vector (x, y) from the tail link's centre to the head link's at t = 0.
    pub start_direction: [f64; 2],
    /// Largest contact normal force of the run (N).
    pub peak_force_n: f64,
    /// Largest magnitude, over links and consecutive [`FORCE_WINDOW_SECS`] windows, of a link's
    /// total contact force averaged over the window (N): what a force sensor with that averaging
    /// window reads at its peak.
    pub peak_window_force_n: f64,
    /// Time average over the steps of the largest contact normal force at each (N).
    pub mean_force_n: f64,
    /// Largest penetration of the run (m).
    pub max_penetration_m: f64,
    /// Largest speed of the centre of mass against the launch direction (m/s; impacts).
    pub rebound_speed_m_per_s: f64,
}

/// Errors of one setting against the reference (fractions; `None`: does not apply).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Errors {
    /// Centre-of-mass end point distance / the reference's net displacement.
    pub com_path: Option<f64>,
    /// Mean forward speed, relative.
    pub forward_speed: Option<f64>,
    /// Direction of travel (rad).
    pub heading_rad: Option<f64>,
    /// RMS joint-angle difference / RMS joint angle.
    pub joint_angles: Option<f64>,
    /// Peak contact force (instantaneous), relative.
    pub peak_force: Option<f64>,
    /// Peak of the 10 ms window-averaged link contact force, relative.
    pub peak_force_10ms: Option<f64>,
    /// Mean contact force, relative.
    pub mean_force: Option<f64>,
    /// Largest penetration, relative.
    pub penetration: Option<f64>,
    /// Rebound speed, relative.
    pub rebound_speed: Option<f64>,
}

impl Errors {
    /// The names of the quantities, in the order of [`Errors::values`].
    pub const NAMES: [&'static str; 9] = [
        "CoM path",
        "forward speed",
        "heading",
        "joint angles",
        "peak contact force",
        "peak force (10 ms)",
        "mean contact force",
        "penetration",
        "rebound speed",
    ];

    /// The errors in the order of [`Errors::NAMES`] (absolute values).
    pub fn values(&self) -> [Option<f64>; 9] {
        [
            self.com_path,
            self.forward_speed,
            self.heading_rad,
            self.joint_angles,
            self.peak_force,
            self.peak_force_10ms,
            self.mean_force,
            self.penetration,
            self.rebound_speed,
        ]
        .map(|v| v.map(f64::abs))
    }

    /// The largest error and its quantity's name (NaN counts as infinitely wrong).
    pub fn worst(&self) -> (f64, &'static str) {
        self.worst_of(Quantities::All)
    }

    /// The largest error among `quantities` and its quantity's name.
    pub fn worst_of(&self, quantities: Quantities) -> (f64, &'static str) {
        let mut worst = (0.0, "-");
        for (k, (v, name)) in self.values().into_iter().zip(Self::NAMES).enumerate() {
            if !quantities.includes(k) {
                continue;
            }
            if let Some(v) = v {
                let v = if v.is_nan() { f64::INFINITY } else { v };
                if v > worst.0 {
                    worst = (v, name);
                }
            }
        }
        worst
    }
}

/// Which quantities of [`Errors::NAMES`] a choice looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantities {
    /// Every quantity.
    All,
    /// Every quantity but the instantaneous peak contact force (sampling-dominated; the
    /// 10 ms peak stays in).
    AllButInstantaneousPeak,
    /// The motion: CoM path, forward speed, heading, joint angles (and an impact's rebound
    /// speed).
    Motion,
}

impl Quantities {
    /// Whether the quantity at index `k` of [`Errors::NAMES`] counts.
    pub fn includes(self, k: usize) -> bool {
        match self {
            Quantities::All => true,
            Quantities::AllButInstantaneousPeak => k != 4,
            Quantities::Motion => k <= 3 || k == 8,
        }
    }

    /// One line for the report.
    pub fn label(self) -> &'static str {
        match self {
            Quantities::All => "every quantity",
            Quantities::AllButInstantaneousPeak => "every quantity but the instantaneous peak force",
            Quantities::Motion => "the motion quantities (path, speed, heading, joint angles, rebound)",
        }
    }
}

/// Relative error `(value − reference) / |reference|`; `None` when the reference is (nearly) 0
/// against `scale` (the quantity does not apply, e.g. a contact force where nothing touches).
pub fn relative_error(value: f64, reference: f64, scale: f64) -> Option<f64> {
    (reference.abs() > 1e-9 * scale.abs().max(1e-300)).then(|| (value - reference) / reference.abs())
}

/// RMS of `a − b` over all samples and entries, divided by the RMS of `b`; `None` when `b` is all
/// zeros or the lengths differ.
pub fn rms_relative_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> Option<f64> {
    if a.len() != b.len() || a.iter().zip(b).any(|(x, y)| x.len() != y.len()) {
        return None;
    }
    let (mut diff, mut norm) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for (p, q) in x.iter().zip(y) {
            diff += (p - q) * (p - q);
            norm += q * q;
        }
    }
    (norm > 0.0).then(|| (diff / norm).sqrt())
}

/// Angle between two directions in the plane (rad, 0 ..= π); `None` if either is zero.
pub fn angle_between(a: [f64; 2], b: [f64; 2]) -> Option<f64> {
    let (na, nb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
    if na == 0.0 || nb == 0.0 {
        return None;
    }
    let cross = a[0] * b[1] - a[1] * b[0];
    let dot = a[0] * b[0] + a[1] * b[1];
    Some(cross.atan2(dot).abs())
}

/// Index of the first sample at or after `t_secs`.
fn sample_at(time_secs: &[f64], t_secs: f64) -> usize {
    time_secs.iter().position(|t| *t >= t_secs - 1e-9).unwrap_or(0)
}

/// Displacement of the centre of mass from `from_secs` to the end (m).
fn displacement(t: &Trajectory, from_secs: f64) -> [f64; 2] {
    let (Some(end), start) = (t.com_m.last(), sample_at(&t.time_secs, from_secs)) else { return [0.0; 2] };
    [end[0] - t.com_m[start][0], end[1] - t.com_m[start][1]]
}

/// Mean speed of the centre of mass along the starting direction from `from_secs` to the end (m/s).
pub fn forward_speed_m_per_s(t: &Trajectory, from_secs: f64) -> f64 {
    let d = displacement(t, from_secs);
    let start = sample_at(&t.time_secs, from_secs);
    let span = t.time_secs.last().map_or(0.0, |end| end - t.time_secs[start]);
    if span <= 0.0 {
        return 0.0;
    }
    (d[0] * t.start_direction[0] + d[1] * t.start_direction[1]) / span
}

/// Errors of `run` against `reference` for a case of `kind`.
pub fn errors(kind: CaseKind, run: &Trajectory, reference: &Trajectory) -> Errors {
    let force_scale = reference.peak_force_n.max(1.0);
    let mut e = Errors {
        peak_force: relative_error(run.peak_force_n, reference.peak_force_n, force_scale),
        peak_force_10ms: relative_error(run.peak_window_force_n, reference.peak_window_force_n, force_scale),
        mean_force: relative_error(run.mean_force_n, reference.mean_force_n, force_scale),
        penetration: relative_error(run.max_penetration_m, reference.max_penetration_m, 1.0),
        ..Errors::default()
    };
    match kind {
        CaseKind::Locomotion { from_secs } => {
            let (Some(a), Some(b), Some(r0)) = (run.com_m.last(), reference.com_m.last(), reference.com_m.first())
            else {
                return e;
            };
            let travelled_m = (b[0] - r0[0]).hypot(b[1] - r0[1]);
            // Below 1 mm of travel the path is not a quantity to compare.
            if travelled_m > 1e-3 {
                e.com_path = Some((a[0] - b[0]).hypot(a[1] - b[1]) / travelled_m);
                e.heading_rad = angle_between(displacement(run, from_secs), displacement(reference, from_secs));
                e.forward_speed = relative_error(
                    forward_speed_m_per_s(run, from_secs),
                    forward_speed_m_per_s(reference, from_secs),
                    1e-3,
                );
            }
            e.joint_angles = rms_relative_difference(&run.joint_angle_rad, &reference.joint_angle_rad);
        }
        CaseKind::Impact { .. } => {
            e.rebound_speed = relative_error(run.rebound_speed_m_per_s, reference.rebound_speed_m_per_s, 1.0);
        }
    }
    e
}

/// Whether a trajectory that the engine accepted has blown up anyway: a non-finite sample or
/// force, or the centre of mass moving faster than `max_speed_m_per_s` between two samples.
/// Returns what is wrong.
pub fn divergence(t: &Trajectory, max_speed_m_per_s: f64) -> Option<String> {
    let scalars = [t.peak_force_n, t.peak_window_force_n, t.mean_force_n, t.max_penetration_m, t.rebound_speed_m_per_s];
    if scalars.iter().any(|v| !v.is_finite()) {
        return Some("a non-finite contact force, penetration or speed".into());
    }
    for (k, (c, q)) in t.com_m.iter().zip(&t.joint_angle_rad).enumerate() {
        if c.iter().chain(q).any(|v| !v.is_finite()) {
            return Some(format!("a non-finite position at t = {} s", t.time_secs[k]));
        }
    }
    for k in 1..t.com_m.len().min(t.time_secs.len()) {
        let (a, b) = (t.com_m[k - 1], t.com_m[k]);
        let dt = t.time_secs[k] - t.time_secs[k - 1];
        let speed = (b[0] - a[0]).hypot(b[1] - a[1]) / dt;
        if dt > 0.0 && speed > max_speed_m_per_s {
            return Some(format!(
                "the centre of mass moved at {speed:.3e} m/s at t = {} s (bound {max_speed_m_per_s} m/s)",
                t.time_secs[k]
            ));
        }
    }
    None
}

/// Centre-of-mass speed bound of [`divergence`] (m/s): the runaway-energy guard's RMS speed.
pub const MAX_COM_SPEED_M_PER_S: f64 = 100.0;

/// How one setting ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    /// Ran to the end.
    Ok,
    /// Diverged: the engine's error or [`divergence`]'s finding.
    Diverged(String),
    /// The config was rejected for this setting (e.g. a contact time constant below its minimum).
    Rejected(String),
}

/// One row of the study.
#[derive(Debug, Clone)]
pub struct Row {
    /// The case's name.
    pub case: String,
    /// The setting.
    pub setting: Setting,
    /// How it ended.
    pub status: Status,
    /// Errors against the reference (when it ran).
    pub errors: Errors,
    /// Steps per wall second of the unrecorded run.
    pub steps_per_sec: f64,
    /// Simulated seconds per wall second of the unrecorded run.
    pub realtime_factor: f64,
}

/// The config of `case` with `setting`.
fn with_setting(case: &Case, setting: Setting) -> Config {
    let mut c = case.config.clone();
    c.general.integrator = setting.integrator;
    c.general.timestep_secs = setting.timestep_secs;
    c.recording.enabled = false;
    c
}

/// Builds the simulation of a case (with its launch velocity).
fn build(case: &Case, config: &Config) -> Result<Simulation, SimError> {
    let mut world = World::from_config(config)?;
    if let CaseKind::Impact { axis, speed_m_per_s } = case.kind {
        world.qvel_mut()[axis] = if axis == 2 { -speed_m_per_s } else { speed_m_per_s };
    }
    world.forward();
    Ok(Simulation::new(config, world))
}

/// Collects a [`Trajectory`] from every step's snapshot.
struct Collector {
    trajectory: Trajectory,
    sample_every: u64,
    steps: u64,
    force_sum: f64,
    rebound_axis: Option<(usize, f64)>,
    /// Per link: sum of the contact force over the current window's steps (N).
    window_sum_n: Vec<[f64; 3]>,
    /// Steps in the current window.
    window_steps: u64,
}

impl Collector {
    fn new(sample_every: u64, rebound_axis: Option<(usize, f64)>) -> Self {
        Collector {
            trajectory: Trajectory::default(),
            sample_every,
            steps: 0,
            force_sum: 0.0,
            rebound_axis,
            window_sum_n: Vec::new(),
            window_steps: 0,
        }
    }

    /// Adds a step's link contact forces to the window; at the window's end, its averages.
    fn add_to_window(&mut self, link_force_n: &[[f64; 3]]) {
        if self.window_sum_n.len() != link_force_n.len() {
            self.window_sum_n = vec![[0.0; 3]; link_force_n.len()];
        }
        for (sum, f) in self.window_sum_n.iter_mut().zip(link_force_n) {
            for i in 0..3 {
                sum[i] += f[i];
            }
        }
        self.window_steps += 1;
        if self.window_steps == self.sample_every {
            let n = self.window_steps as f64;
            for sum in &mut self.window_sum_n {
                let mean = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt() / n;
                self.trajectory.peak_window_force_n = self.trajectory.peak_window_force_n.max(mean);
                *sum = [0.0; 3];
            }
            self.window_steps = 0;
        }
    }
}

impl Observer<SimError> for Collector {
    fn on_record(&mut self, view: &StepView<'_>, s: &Snapshot) -> Result<(), SimError> {
        let t = &mut self.trajectory;
        let peak = s.peak_contact_force_n();
        t.peak_force_n = t.peak_force_n.max(peak);
        self.force_sum += peak;
        self.steps += 1;
        t.max_penetration_m = t.max_penetration_m.max(s.max_penetration_m());
        self.add_to_window(&s.link_contact_force_n);
        let t = &mut self.trajectory;
        if view.k == 0 && s.link_position_m.len() > 1 {
            let (h, l) = (s.link_position_m[0], s.link_position_m[s.link_position_m.len() - 1]);
            let n = (h[0] - l[0]).hypot(h[1] - l[1]).max(1e-12);
            t.start_direction = [(h[0] - l[0]) / n, (h[1] - l[1]) / n];
        }
        if let Some((axis, sign)) = self.rebound_axis {
            let mass: f64 = s.link_mass_kg.iter().sum();
            let p: f64 = s.link_mass_kg.iter().zip(&s.link_velocity_m_per_s).map(|(m, v)| m * v[axis]).sum();
            t.rebound_speed_m_per_s = t.rebound_speed_m_per_s.max(sign * p / mass.max(1e-300));
        }
        if view.k.is_multiple_of(self.sample_every) {
            let c = s.centre_of_mass_m();
            t.time_secs.push(s.time_secs);
            t.com_m.push([c[0], c[1]]);
            t.joint_angle_rad.push(s.joint_angle_rad.clone());
        }
        Ok(())
    }

    fn on_end(&mut self, _view: &StepView<'_>, _completed: bool) -> Result<(), SimError> {
        self.trajectory.mean_force_n = self.force_sum / self.steps.max(1) as f64;
        Ok(())
    }
}

/// Steps of `config`'s duration at its timestep.
fn steps_of(config: &Config) -> u64 {
    (config.general.duration_secs / config.general.timestep_secs).round() as u64
}

/// Runs `case` with `setting`, recording every step; the trajectory, or how it ended.
pub fn trajectory(case: &Case, setting: Setting) -> Result<Trajectory, Status> {
    let config = with_setting(case, setting);
    config.validate().map_err(|e| Status::Rejected(e.to_string()))?;
    let mut sim = build(case, &config).map_err(|e| match e {
        SimError::Config(_) | SimError::ModelRejected { .. } => Status::Rejected(e.to_string()),
        other => Status::Diverged(other.to_string()),
    })?;
    let sample_every = ((SAMPLE_PERIOD_SECS / setting.timestep_secs).round() as u64).max(1);
    let rebound_axis = match case.kind {
        CaseKind::Impact { axis, .. } => Some((axis, if axis == 2 { 1.0 } else { -1.0 })),
        CaseKind::Locomotion { .. } => None,
    };
    let mut collector = Collector::new(sample_every, rebound_axis);
    let plan = crate::sim::LoopPlan { steps: steps_of(&config), record_every_n_steps: 1 };
    let mut poll = crate::interrupt::Poll::new(format!("{} {}", case.name, setting.label()));
    sim.run::<SimError>(plan, &mut [&mut collector, &mut poll]).map_err(|e| Status::Diverged(e.to_string()))?;
    match divergence(&collector.trajectory, MAX_COM_SPEED_M_PER_S) {
        Some(what) => Err(Status::Diverged(what)),
        None => Ok(collector.trajectory),
    }
}

/// Wall-clock cost of `case` with `setting`, recording off: (steps per second, simulated seconds
/// per wall second), the best of `repeats` runs. Model compilation is not counted.
pub fn cost(case: &Case, setting: Setting, repeats: usize) -> Result<(f64, f64), Status> {
    let config = with_setting(case, setting);
    let steps = steps_of(&config);
    let mut best = 0.0f64;
    for _ in 0..repeats.max(1) {
        if crate::interrupt::requested() {
            break;
        }
        let mut sim = build(case, &config).map_err(|e| Status::Rejected(e.to_string()))?;
        let plan = crate::sim::LoopPlan { steps, record_every_n_steps: 0 };
        let mut poll = crate::interrupt::Poll::new(format!("{} {}", case.name, setting.label()));
        let start = Instant::now();
        // A diverging run is timed up to where it stopped.
        let _ = sim.run::<SimError>(plan, &mut [&mut poll]);
        let secs = start.elapsed().as_secs_f64().max(1e-9);
        best = best.max(sim.steps() as f64 / secs);
    }
    Ok((best, best * setting.timestep_secs))
}

/// The study's cases. Full: the default job (as shipped: cylinder path), the default job on a
/// bare floor, the same with fixed contact time constants (stick 50 ms, environment 20 ms, the
/// values "auto" gives at 10 ms), every Coulomb case of experiment III (isotropic 0.5,
/// frictionless, anisotropic ratio 1, 2, 5, 10, 20; the viscous cases are left out: a smooth
/// force law without contacts to resolve), and two impacts of one link at 5 m/s (onto the floor, into a peg). Quick: the default
/// job on a bare floor for 3 s and the floor impact.
pub fn cases(base: &Config, quick: bool) -> Vec<Case> {
    let duration_secs = if quick { 3.0 } else { 10.0 };
    let mut out = Vec::new();
    let mut job = base.clone();
    job.general.duration_secs = duration_secs;
    let ramp = job.gait.ramp_secs.min(duration_secs / 2.0);
    let locomotion = CaseKind::Locomotion { from_secs: ramp };
    if !quick {
        out.push(Case {
            name: "default-job".into(),
            description: "the default job as shipped (10 links, sine wave, cylinder path, stick_slip floor)".into(),
            config: job.clone(),
            kind: locomotion,
        });
    }
    let mut bare = job.clone();
    bare.terrain.kind = TerrainKind::None;
    out.push(Case {
        name: "default-bare-floor".into(),
        description: "the default job on a bare floor (terrain none)".into(),
        config: bare.clone(),
        kind: locomotion,
    });
    if !quick {
        let mut fixed = bare.clone();
        fixed.physics.floor_stick_time_constant_secs = AutoSecs::Secs(0.05);
        fixed.physics.environment_contact_time_constant_secs = AutoSecs::Secs(0.02);
        out.push(Case {
            name: "default-bare-floor-fixed-contacts".into(),
            description: "the default job on a bare floor with fixed contact time constants (stick 50 ms, \
                          environment 20 ms: \"auto\" at 10 ms), the reference too"
                .into(),
            config: fixed,
            kind: locomotion,
        });
        // Every Coulomb case of experiment III (the same list as `experiment undulation`).
        let mut u = crate::experiments::locomotion_undulation_config(base, true);
        u.general.duration_secs = duration_secs;
        let from_secs = u.gait.ramp_secs;
        let kind = CaseKind::Locomotion { from_secs };
        for (name, config) in crate::experiments::locomotion_undulation_coulomb_cases(&u) {
            let description = match config.ground.model {
                GroundModel::Anisotropic => format!(
                    "experiment III, anisotropic Coulomb friction, lateral {} / axial {} (ratio {})",
                    config.ground.lateral_friction,
                    config.ground.axial_friction,
                    config.ground.lateral_friction / config.ground.axial_friction
                ),
                _ => format!(
                    "experiment III, isotropic Coulomb friction {} (floor and between links)",
                    config.snake.ground_friction[0]
                ),
            };
            out.push(Case { name, description, config, kind });
        }
    }
    let impacts: &[(usize, &str)] = if quick { &[(2, "floor")] } else { &[(2, "floor"), (0, "peg")] };
    for &(axis, what) in impacts {
        let mut c = crate::experiments::collision_case_bodies(base, 1);
        c.general.duration_secs = 0.2;
        if axis == 2 {
            c.snake.head_position_m[2] = 0.02;
        }
        out.push(Case {
            name: format!("impact-{what}"),
            description: format!(
                "one link (0.3 kg, radius 0.08 m) at {} m/s {}, 0.2 s",
                crate::experiments::LAUNCH_SPEED_M_PER_S,
                if axis == 2 { "onto the floor from 2 cm" } else { "into a peg of radius 0.2 m 0.3 m ahead" }
            ),
            config: c,
            kind: CaseKind::Impact { axis, speed_m_per_s: crate::experiments::LAUNCH_SPEED_M_PER_S },
        });
    }
    out
}

/// The study's options.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Settings compared with the reference.
    pub settings: Vec<Setting>,
    /// The reference setting.
    pub reference: Setting,
    /// Timed runs per setting (the fastest counts).
    pub repeats: usize,
    /// Where the report, table and plots go.
    pub out_dir: PathBuf,
}

/// The study's result.
#[derive(Debug, Clone)]
pub struct Study {
    /// The cases.
    pub cases: Vec<Case>,
    /// One row per case and setting, the reference's first for each case.
    pub rows: Vec<Row>,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// The report (Markdown).
    pub report: String,
}

/// Runs the study: every case with the reference and every setting (the recorded runs in
/// parallel, on rayon's pool), then the timed runs one after another; writes `accuracy.md`,
/// `accuracy.csv` and the work-precision plots into `options.out_dir`.
pub fn run_study(cases: Vec<Case>, options: &StudyOptions) -> Result<Study, RunError> {
    use rayon::prelude::*;
    let mut jobs: Vec<(usize, Setting)> = Vec::new();
    for c in 0..cases.len() {
        jobs.push((c, options.reference));
        jobs.extend(options.settings.iter().map(|s| (c, *s)));
    }
    let trajectories: Vec<Result<Trajectory, Status>> = jobs
        .par_iter()
        .map(|&(c, s)| {
            if crate::interrupt::requested() {
                return Err(Status::Rejected("interrupted".into()));
            }
            let t = trajectory(&cases[c], s);
            eprintln!("study: {} {} recorded", cases[c].name, s.label());
            t
        })
        .collect();
    // A signal: what ran is not a study; nothing is written (exit code 130).
    crate::interrupt::check(|| "while the study's runs were recorded; nothing was written".into())?;
    let mut rows = Vec::new();
    for (k, &(c, setting)) in jobs.iter().enumerate() {
        let case = &cases[c];
        let reference = trajectories[jobs.iter().position(|&(cc, _)| cc == c).unwrap_or(0)].as_ref().ok();
        let (status, errors) = match (&trajectories[k], reference) {
            (Ok(t), Some(r)) => (Status::Ok, errors(case.kind, t, r)),
            (Ok(_), None) => (Status::Rejected("the reference run failed".into()), Errors::default()),
            (Err(s), _) => (s.clone(), Errors::default()),
        };
        let (steps_per_sec, realtime_factor) = match &status {
            Status::Rejected(_) => (0.0, 0.0),
            _ => cost(case, setting, options.repeats).unwrap_or((0.0, 0.0)),
        };
        crate::interrupt::check(|| format!("while {} {} was timed; nothing was written", case.name, setting.label()))?;
        eprintln!("study: {} {} timed: {realtime_factor:.1} x real time", case.name, setting.label());
        rows.push(Row { case: case.name.clone(), setting, status, errors, steps_per_sec, realtime_factor });
    }
    std::fs::create_dir_all(&options.out_dir).map_err(|source| io_error(&options.out_dir, source))?;
    let mut files = Vec::new();
    let csv = write_in(&options.out_dir, "accuracy.csv", &csv_text(&rows))?;
    files.push(csv);
    for case in &cases {
        files.extend(plot_case(&options.out_dir, case, &rows, options.reference)?);
    }
    let report = report_text(&cases, &rows, options);
    let md = write_in(&options.out_dir, "accuracy.md", &report)?;
    files.push(md);
    Ok(Study { cases, rows, files, report })
}

/// Writes `name` into `dir` by [`crate::files`]' writer rule (never through a link).
fn write_in(dir: &Path, name: &str, text: &str) -> Result<PathBuf, RunError> {
    crate::files::write_in(dir, Path::new(name), text.as_bytes()).map_err(|e| match e {
        crate::files::FileError::Io { path, source, .. } => io_error(&path, source),
        other => io_error(dir, std::io::Error::other(other.to_string())),
    })
}

fn io_error(path: &Path, source: std::io::Error) -> RunError {
    RunError::Record(crate::record::RecordError::Io { path: path.to_path_buf(), source })
}

fn fmt_error(v: Option<f64>, degrees: bool) -> String {
    match v {
        None => "-".into(),
        Some(v) if degrees => format!("{:.2}°", v.to_degrees()),
        Some(v) => format!("{:+.2} %", 100.0 * v),
    }
}

fn status_text(s: &Status) -> String {
    match s {
        Status::Ok => "ok".into(),
        Status::Diverged(m) => format!("DIVERGED: {}", m.replace('|', "/").replace('\n', " ")),
        Status::Rejected(m) => format!("rejected: {}", m.replace('|', "/").replace('\n', " ")),
    }
}

/// The rows as CSV (one line per case and setting).
pub fn csv_text(rows: &[Row]) -> String {
    let mut s = String::from(
        "case,integrator,timestep_s,status,com_path_err,forward_speed_err,heading_err_rad,joint_angle_err,\
         peak_force_err,peak_force_10ms_err,mean_force_err,penetration_err,rebound_speed_err,worst_err,steps_per_s,realtime_factor\n",
    );
    for r in rows {
        let v = r.errors.values();
        let cell = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:.6e}"));
        let status = match &r.status {
            Status::Ok => "ok",
            Status::Diverged(_) => "diverged",
            Status::Rejected(_) => "rejected",
        };
        let worst = if r.status == Status::Ok { format!("{:.6e}", r.errors.worst().0) } else { String::new() };
        let _ = writeln!(
            s,
            "{},{},{},{status},{},{worst},{:.1},{:.3}",
            r.case,
            r.setting.integrator.mjcf_name(),
            r.setting.timestep_secs,
            v.iter().map(|x| cell(*x)).collect::<Vec<_>>().join(","),
            r.steps_per_sec,
            r.realtime_factor
        );
    }
    s
}

/// The recommendation: the cheapest setting whose worst error among `quantities` over every case
/// is within `tolerance`, by the summed wall time of the cases' timed runs. `None` if none
/// qualifies.
pub fn cheapest_within(
    rows: &[Row],
    settings: &[Setting],
    tolerance: f64,
    quantities: Quantities,
) -> Option<(Setting, f64, f64)> {
    let mut best: Option<(Setting, f64, f64)> = None;
    for s in settings {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.setting == *s).collect();
        if mine.is_empty() || mine.iter().any(|r| r.status != Status::Ok || r.realtime_factor <= 0.0) {
            continue;
        }
        let worst = mine.iter().map(|r| r.errors.worst_of(quantities).0).fold(0.0, f64::max);
        if worst > tolerance {
            continue;
        }
        // Wall seconds per simulated second, summed over the cases.
        let wall: f64 = mine.iter().map(|r| 1.0 / r.realtime_factor).sum();
        if best.is_none_or(|(_, w, _)| wall < w) {
            best = Some((*s, wall, worst));
        }
    }
    best
}

fn report_text(cases: &[Case], rows: &[Row], options: &StudyOptions) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Accuracy study\n\nSimSerpent {}, MuJoCo {}. Reference: {}. Errors against the reference \
         (see `simserpent::study`); cost from unrecorded runs (best of {}), wall clock on this machine.\n",
        env!("CARGO_PKG_VERSION"),
        crate::sim::engine_version(),
        options.reference.label(),
        options.repeats
    );
    for case in cases {
        let _ = writeln!(
            s,
            "## {}\n\n{}; {} s simulated.\n",
            case.name, case.description, case.config.general.duration_secs
        );
        let _ = writeln!(
            s,
            "| setting | CoM path | fwd speed | heading | joint angles | peak force (instant) | peak force (10 ms) | \
             mean force | penetration | rebound | worst | steps/s | real-time factor | status |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        for r in rows.iter().filter(|r| r.case == case.name) {
            let v = r.errors.values();
            let ok = r.status == Status::Ok;
            let cells: Vec<String> = if ok {
                v.iter().enumerate().map(|(i, x)| fmt_error(*x, i == 2)).collect()
            } else {
                vec!["-".into(); 9]
            };
            let worst =
                if ok { format!("{:.2} % ({})", 100.0 * r.errors.worst().0, r.errors.worst().1) } else { "-".into() };
            let _ = writeln!(
                s,
                "| {}{} | {} | {worst} | {:.0} | {:.1} | {} |",
                r.setting.label(),
                if r.setting == options.reference { " (reference)" } else { "" },
                cells.join(" | "),
                r.steps_per_sec,
                r.realtime_factor,
                status_text(&r.status)
            );
        }
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "## Recommendation\n\nThe cheapest setting within the tolerance on every case of this run. The instantaneous \
         peak force is the largest force at one step, so it depends on where the steps fall in a contact transient; \
         the 10 ms peak is what a force sensor averaging over 10 ms reads (the impulse per 10 ms), the same windows \
         at every step size.\n"
    );
    for (tolerance, quantities) in [
        (SAME_ANSWERS, Quantities::All),
        (SAME_ANSWERS, Quantities::AllButInstantaneousPeak),
        (RL_TOLERANCE, Quantities::All),
        (RL_TOLERANCE, Quantities::Motion),
    ] {
        let what = format!("within {:.0} % on {}", 100.0 * tolerance, quantities.label());
        match cheapest_within(rows, &options.settings, tolerance, quantities) {
            Some((setting, wall, worst)) => {
                let _ = writeln!(
                    s,
                    "- {what}: **{}** — worst error {:.2} % over all cases, {:.3} wall s per simulated s summed over \
                     the cases",
                    setting.label(),
                    100.0 * worst,
                    wall
                );
            }
            None => {
                let _ = writeln!(s, "- {what}: no setting of the study qualifies");
            }
        }
    }
    s
}

fn plot_case(dir: &Path, case: &Case, rows: &[Row], reference: Setting) -> Result<Vec<PathBuf>, RunError> {
    let mut series = Vec::new();
    for integrator in INTEGRATORS {
        let points: Vec<(f64, f64, String)> = rows
            .iter()
            .filter(|r| {
                r.case == case.name
                    && r.setting.integrator == integrator
                    && r.setting != reference
                    && r.status == Status::Ok
                    && r.realtime_factor > 0.0
            })
            .map(|r| {
                (1.0 / r.realtime_factor, r.errors.worst().0.max(1e-5), format!("{} ms", r.setting.timestep_secs * 1e3))
            })
            .collect();
        series.push((integrator.mjcf_name().to_string(), points));
    }
    let failed: Vec<String> =
        rows.iter().filter(|r| r.case == case.name && r.status != Status::Ok).map(|r| r.setting.label()).collect();
    let title = if failed.is_empty() {
        format!("{}: worst error vs cost", case.name)
    } else {
        format!("{}: worst error vs cost (diverged/rejected: {})", case.name, failed.join(", "))
    };
    Ok(crate::plot::plot_work_precision(
        dir,
        &format!("work_precision_{}", case.name),
        &title,
        "wall seconds per simulated second",
        "worst error vs RK4 0.1 ms (fraction)",
        &series,
        &[SAME_ANSWERS, RL_TOLERANCE],
    )?)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn straight(speed: f64, direction: [f64; 2]) -> Trajectory {
        let time_secs: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
        Trajectory {
            com_m: time_secs.iter().map(|t| [speed * t * direction[0], speed * t * direction[1]]).collect(),
            joint_angle_rad: time_secs.iter().map(|t| vec![t.sin(), (2.0 * t).cos()]).collect(),
            time_secs,
            start_direction: [1.0, 0.0],
            peak_force_n: 10.0,
            peak_window_force_n: 4.0,
            mean_force_n: 3.0,
            max_penetration_m: 0.002,
            rebound_speed_m_per_s: 1.0,
        }
    }

    #[test]
    fn relative_error_is_signed_and_none_at_a_zero_reference() {
        assert_eq!(relative_error(1.02, 1.0, 1.0), Some(0.020000000000000018));
        assert!((relative_error(-0.98, -1.0, 1.0).unwrap() - 0.02).abs() < 1e-15);
        assert_eq!(relative_error(5.0, 0.0, 1.0), None);
    }

    #[test]
    fn rms_relative_difference_of_known_signals() {
        // b = (3, 4): RMS 5/√2; a − b = (0.3, 0.4): RMS 0.5/√2 → 0.1.
        let a = vec![vec![3.3, 4.4]];
        let b = vec![vec![3.0, 4.0]];
        assert!((rms_relative_difference(&a, &b).unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(rms_relative_difference(&a, &[vec![0.0, 0.0]]), None);
        assert_eq!(rms_relative_difference(&a, &[]), None);
    }

    #[test]
    fn angle_between_known_directions() {
        assert!((angle_between([1.0, 0.0], [0.0, 2.0]).unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((angle_between([1.0, 0.0], [-1.0, -1e-300]).unwrap() - std::f64::consts::PI).abs() < 1e-12);
        assert_eq!(angle_between([0.0, 0.0], [1.0, 0.0]), None);
    }

    #[test]
    fn errors_of_a_slower_turned_run() {
        let reference = straight(0.5, [1.0, 0.0]);
        // 1 % slower, heading 0.01 rad to the left.
        let run = Trajectory { peak_force_n: 11.0, ..straight(0.495, [0.01f64.cos(), 0.01f64.sin()]) };
        let e = errors(CaseKind::Locomotion { from_secs: 0.0 }, &run, &reference);
        assert!((e.heading_rad.unwrap() - 0.01).abs() < 1e-12);
        // Speed along the start direction: 0.495·cos(0.01).
        assert!((e.forward_speed.unwrap() - (0.99 * 0.01f64.cos() - 1.0)).abs() < 1e-12);
        // End points 5 m and 4.95 m away at 0.01 rad apart, over 5 m travelled.
        let (a, b) = (4.95, 5.0);
        let gap = (a * a + b * b - 2.0 * a * b * 0.01f64.cos()).sqrt();
        assert!((e.com_path.unwrap() - gap / 5.0).abs() < 1e-12);
        assert_eq!(e.joint_angles, Some(0.0));
        assert!((e.peak_force.unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(e.mean_force, Some(0.0));
        assert_eq!(e.rebound_speed, None);
        assert!((e.worst().0 - 0.1).abs() < 1e-12);
        assert_eq!(e.worst().1, "peak contact force");
    }

    #[test]
    fn an_impact_compares_the_rebound_and_not_the_path() {
        let reference = straight(0.0, [1.0, 0.0]);
        let run = Trajectory { rebound_speed_m_per_s: 0.97, ..reference.clone() };
        let e = errors(CaseKind::Impact { axis: 2, speed_m_per_s: 5.0 }, &run, &reference);
        assert!((e.rebound_speed.unwrap() + 0.03).abs() < 1e-12);
        assert_eq!((e.com_path, e.forward_speed, e.heading_rad, e.joint_angles), (None, None, None, None));
    }

    #[test]
    fn divergence_finds_non_finite_values_and_runaway_speed() {
        let fine = straight(0.5, [1.0, 0.0]);
        assert_eq!(divergence(&fine, MAX_COM_SPEED_M_PER_S), None);
        let mut nan = fine.clone();
        nan.joint_angle_rad[7][1] = f64::NAN;
        assert!(divergence(&nan, MAX_COM_SPEED_M_PER_S).unwrap().contains("t = 0.7"));
        let mut inf = fine.clone();
        inf.peak_force_n = f64::INFINITY;
        assert!(divergence(&inf, MAX_COM_SPEED_M_PER_S).is_some());
        // A jump of 20 m within 0.1 s: 200 m/s.
        let mut jump = fine.clone();
        jump.com_m[50][0] += 20.0;
        assert!(divergence(&jump, MAX_COM_SPEED_M_PER_S).unwrap().contains("t = 5"));
        // NaN errors count as the worst.
        let e = Errors { peak_force: Some(f64::NAN), mean_force: Some(0.5), ..Errors::default() };
        assert_eq!(e.worst(), (f64::INFINITY, "peak contact force"));
    }

    #[test]
    fn cheapest_within_skips_diverged_and_inaccurate_settings() {
        let s = |i, dt| Setting { integrator: i, timestep_secs: dt };
        let (a, b, c) = (s(Integrator::RK4, 0.001), s(Integrator::Euler, 0.002), s(Integrator::Euler, 0.01));
        let row = |setting, err: f64, rtf, status| Row {
            case: "x".into(),
            setting,
            status,
            errors: Errors { penetration: Some(err), ..Errors::default() },
            steps_per_sec: rtf / setting.timestep_secs,
            realtime_factor: rtf,
        };
        let rows = vec![
            row(a, 0.001, 5.0, Status::Ok),
            row(b, 0.015, 40.0, Status::Ok),
            row(c, 0.0, 0.0, Status::Diverged("nan".into())),
        ];
        let (best, wall, worst) = cheapest_within(&rows, &[a, b, c], 0.02, Quantities::All).unwrap();
        assert_eq!(best, b);
        assert!((wall - 1.0 / 40.0).abs() < 1e-15 && (worst - 0.015).abs() < 1e-15);
        assert_eq!(cheapest_within(&rows, &[a, b, c], 0.01, Quantities::All).unwrap().0, a);
        assert_eq!(cheapest_within(&rows, &[c], 0.5, Quantities::All), None);
        // The errors are penetration errors: the motion alone lets the cheapest through.
        assert_eq!(cheapest_within(&rows, &[a, b], 0.01, Quantities::Motion).unwrap().0, b);
        assert_eq!(cheapest_within(&rows, &[a, b], 0.01, Quantities::AllButInstantaneousPeak).unwrap().0, a);
    }

    #[test]
    fn quantities_select_by_name() {
        let e = Errors {
            com_path: Some(0.01),
            peak_force: Some(0.3),
            peak_force_10ms: Some(0.04),
            rebound_speed: Some(0.02),
            ..Errors::default()
        };
        assert_eq!(e.worst_of(Quantities::All), (0.3, "peak contact force"));
        assert_eq!(e.worst_of(Quantities::AllButInstantaneousPeak), (0.04, "peak force (10 ms)"));
        assert_eq!(e.worst_of(Quantities::Motion), (0.02, "rebound speed"));
    }

    #[test]
    fn the_window_peak_is_the_impulse_per_window_wherever_a_spike_falls() {
        // Two links, 10 steps per window. An impulse of 0.05 N·s·(steps/s) on link 1 as one
        // spike of 50 N at one step, or spread as 5 N over ten steps: the same window mean, 5 N,
        // while the instantaneous peak differs tenfold.
        let mut spike = Collector::new(10, None);
        let mut spread = Collector::new(10, None);
        for k in 0..30 {
            let f = if k == 13 { 50.0 } else { 0.0 };
            spike.add_to_window(&[[0.0, 0.0, 1.0], [0.0, 0.0, f]]);
            let g = if (10..20).contains(&k) { 5.0 } else { 0.0 };
            spread.add_to_window(&[[0.0, 0.0, 1.0], [0.0, g, 0.0]]);
        }
        assert_eq!(spike.trajectory.peak_window_force_n, 5.0);
        assert_eq!(spread.trajectory.peak_window_force_n, 5.0);
        // A steady 1 N on link 0 alone reads 1 N; opposite forces within a window cancel
        // (the window mean of the vector, as a sensor's filter).
        let mut steady = Collector::new(10, None);
        for k in 0..20 {
            let s = if k % 2 == 0 { 3.0 } else { -3.0 };
            steady.add_to_window(&[[0.0, 0.0, 1.0], [s, 0.0, 0.0]]);
        }
        assert!((steady.trajectory.peak_window_force_n - 1.0).abs() < 1e-15);
    }

    #[test]
    fn the_study_has_every_integrator_at_every_step() {
        let all = all_settings();
        assert_eq!(all.len(), 18);
        for dt in TIMESTEPS_SECS {
            let per_sample = SAMPLE_PERIOD_SECS / dt;
            assert!((per_sample - per_sample.round()).abs() < 1e-9, "{dt} s does not divide the sample period");
        }
    }
}

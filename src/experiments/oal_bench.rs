//! Experiment `oal-bench`: the obstacle-aided locomotion benchmark (SPEC "How the field judges
//! obstacle-aided locomotion").
//!
//! A 10-link snake on SimSerpent's stick–slip floor runs one base gait, the ordinary lateral
//! undulation [`BASE_AMPLITUDE_DEG`]/[`BASE_PHASE_LAG_DEG`] (the wave travels toward the tail) at
//! [`FREQUENCY_HZ`], through obstacle fields, under several **conditions** on the same fields
//! (paired):
//!
//! - `open_loop`: the gait alone (feedback off; every contact law of `control` with
//!   `feedback = false` sends exactly these set-points);
//! - `passive_kp<k>`: the same open-loop gait on soft position servos (kp = k N·m/rad, kv =
//!   kp/100), for every k of the sweep; the gain with the best tuning-field success rate (then
//!   speed) per floor is *the* passive-compliance baseline;
//! - each contact law (`follow_the_leader_reflex`, `directional_admittance`, `jam_resolution`),
//!   fed the step loop's contact estimates (`_est`) and the simulator's true contacts (`_true`),
//!   on the stiff servos or, with [`Bench::law_servo_kp_nm_per_rad`], on soft ones (with the
//!   passive gain, a law's feedback-off run is the passive baseline);
//! - any controller a caller plugs in ([`Plugged`]).
//!
//! **Floors**: `isotropic` (isotropic Coulomb friction: the base gait's bare-floor speed is ≤ 0,
//! so every millimetre forward is peg-aided; the report measures it) and `anisotropic` (the
//! default floor, the same gait); the report gives each floor's bare-floor speed of the base gait
//! and of the same gait on each passive gain's servos (what softening alone does to the gait).
//! **Layouts** in two families: `lattice` (square and hexagonal
//! lattices, spacings λ/8, λ/6, λ/4 of the body's wavelength λ = 360°/δ link lengths, shifted
//! by a seeded offset per field) and `random` (uniform fields at 1.5, 3 and 4.5 pegs/m², centres
//! ≥ 0.3 m apart); field i of a family has layout i mod (layouts of the family). **Seeds**: the
//! tuning fields are 0..n_tune and the held-out fields start at [`HELD_OUT_FIRST_SEED`]; every
//! figure the report checks is on held-out fields.
//!
//! **Metrics** per run: success (the centre of mass crosses the goal line two body lengths ahead
//! of where it started, along +x, within the time limit; the run stops there), jams per minute
//! (a jam: a [`JAM_WINDOW_SECS`] window after the ramp-in in which the farthest forward position
//! grows by less than [`JAM_PROGRESS_M`]; counted again after each window), speed in body lengths
//! per gait cycle (after the ramp-in), exit heading (the direction of the centre of mass's motion
//! over the last [`EXIT_WINDOW_SECS`]). Per condition: the success rate and median speed with 90 %
//! bootstrap intervals over the fields; per contact law: paired differences (success, speed)
//! against `open_loop` and against the passive baseline, and estimated against true contacts,
//! with 90 % bootstrap intervals (seeded resampling of the fields: the same runs give the same
//! intervals).
//!
//! Files: `oal_runs.csv` (every run), `oal_summary.csv`, `oal_paired.csv`, `plots/`.

use super::ExperimentError;
use super::report::{Check, Section, sig};
use crate::config::{Config, ContactSource, ControllerKind, GaitKind, GroundModel, PegLayout};
use crate::control::Controller;
use crate::run::RunError;
use crate::sim::{LoopPlan, Observer, SimError, Simulation, StepView, World};
use crate::state::Snapshot;
use std::path::Path;
use std::sync::Arc;

/// The base gait: amplitude (degrees), phase lag between joints (degrees; > 0: toward the tail),
/// frequency (Hz).
pub const BASE_AMPLITUDE_DEG: f64 = 80.0;
pub const BASE_PHASE_LAG_DEG: f64 = 30.0;
pub const FREQUENCY_HZ: f64 = 0.5;
/// Position servos of every run but the passive-compliance ones (N·m/rad, N·m·s/rad, N·m).
pub const SERVO_KP_NM_PER_RAD: f64 = 20.0;
pub const SERVO_KV_NM_S_PER_RAD: f64 = 0.2;
pub const TORQUE_LIMIT_NM: f64 = 10.0;
/// The passive-compliance sweep (position servo kp, N·m/rad; kv = kp/100).
pub const PASSIVE_KP_NM_PER_RAD: [f64; 3] = [10.0, 5.0, 2.5];
/// The goal line: this many body lengths ahead of the starting centre of mass.
pub const GOAL_BODY_LENGTHS: f64 = 2.0;
/// The jam rule.
pub const JAM_WINDOW_SECS: f64 = 5.0;
pub const JAM_PROGRESS_M: f64 = 0.02;
/// The exit heading: direction of the centre of mass's motion over this last stretch (s).
pub const EXIT_WINDOW_SECS: f64 = 4.0;
/// The first held-out seed; tuning seeds are 0..n_tune (< this).
pub const HELD_OUT_FIRST_SEED: u64 = 1000;
/// Record the centre of mass every this many steps.
const RECORD_EVERY: u64 = 50;
/// Lattice spacings as fractions of the body's wavelength.
pub const LATTICE_SPACING_OF_WAVELENGTH: [f64; 3] = [1.0 / 8.0, 1.0 / 6.0, 1.0 / 4.0];
/// Random-field densities (pegs per m²) and the least centre distance (m).
pub const RANDOM_PEGS_PER_M2: [f64; 3] = [1.5, 3.0, 4.5];
const RANDOM_SPACING_M: f64 = 0.3;
/// Peg centres lie in this rectangle (m); the snake starts with its head at the origin along +x.
const REGION_MIN_M: [f64; 2] = [-2.6, -1.6];
const REGION_MAX_M: [f64; 2] = [5.0, 1.6];
/// Bootstrap resamples of every interval.
const RESAMPLES: usize = 2000;

/// The floor of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Floor {
    /// Isotropic Coulomb friction.
    Isotropic,
    /// The default anisotropic floor.
    Anisotropic,
}

impl Floor {
    /// The floor named `name` ("isotropic", "anisotropic").
    pub fn from_name(name: &str) -> Option<Floor> {
        [Floor::Isotropic, Floor::Anisotropic].into_iter().find(|f| f.name() == name)
    }

    /// Its name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Floor::Isotropic => "isotropic",
            Floor::Anisotropic => "anisotropic",
        }
    }
}

/// A layout family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// Square and hexagonal lattices at three spacings.
    Lattice,
    /// Random fields at three densities.
    Random,
}

impl Family {
    /// The family named `name` ("lattice", "random").
    pub fn from_name(name: &str) -> Option<Family> {
        [Family::Lattice, Family::Random].into_iter().find(|f| f.name() == name)
    }

    /// Its name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Family::Lattice => "lattice",
            Family::Random => "random",
        }
    }
}

/// One obstacle layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Layout {
    /// A square lattice, spacing as a fraction of the wavelength.
    Square(f64),
    /// A hexagonal lattice, spacing as a fraction of the wavelength.
    Hexagonal(f64),
    /// A random field, pegs per m².
    Random(f64),
    /// No pegs (the bare floor).
    Bare,
}

impl Layout {
    /// The layout of field `index` of `family`.
    pub fn of(family: Family, index: u64) -> Layout {
        match family {
            Family::Lattice => {
                let k = (index % 6) as usize;
                let s = LATTICE_SPACING_OF_WAVELENGTH[k / 2];
                if k.is_multiple_of(2) { Layout::Square(s) } else { Layout::Hexagonal(s) }
            }
            Family::Random => Layout::Random(RANDOM_PEGS_PER_M2[(index % 3) as usize]),
        }
    }

    /// A short name ("square λ/8", "random 3 /m²").
    pub fn name(self) -> String {
        let frac = |s: f64| format!("λ/{}", sig(1.0 / s));
        match self {
            Layout::Square(s) => format!("square {}", frac(s)),
            Layout::Hexagonal(s) => format!("hexagonal {}", frac(s)),
            Layout::Random(d) => format!("random {} /m²", sig(d)),
            Layout::Bare => "bare".to_string(),
        }
    }
}

/// Builds a controller for a run from the run's config and its number of joints.
pub type MakeController = Arc<dyn Fn(&Config, usize) -> Box<dyn Controller> + Send + Sync>;

/// A controller plugged into the benchmark: built per run from the run's config and its number
/// of joints. It runs on the benchmark's base gait settings (`config.gait.sine_wave`) and servos.
#[derive(Clone)]
pub struct Plugged {
    /// Its condition name in the tables.
    pub name: String,
    /// Builds it for a run.
    pub make: MakeController,
    /// Whether its runs need the step loop's contact estimates (`[estimation]` on).
    pub estimation: bool,
}

/// What a condition runs.
#[derive(Clone)]
enum Kind {
    OpenLoop,
    Passive(f64),
    Law(ControllerKind, ContactSource),
    Plugged(Plugged),
}

/// A condition: name and what it runs.
#[derive(Clone)]
pub struct Condition {
    name: String,
    kind: Kind,
}

impl Condition {
    /// Its name.
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// The contact laws of `control`, as conditions (name, controller).
pub const LAWS: [(&str, ControllerKind); 3] = [
    ("follow_the_leader_reflex", ControllerKind::FollowTheLeaderReflex),
    ("directional_admittance", ControllerKind::DirectionalAdmittance),
    ("jam_resolution", ControllerKind::JamResolution),
];

/// The benchmark's size and conditions.
#[derive(Clone)]
pub struct Bench {
    /// Tuning fields per family (seeds 0..n).
    pub tuning_fields: u64,
    /// Held-out fields per family (seeds from [`HELD_OUT_FIRST_SEED`]).
    pub held_out_fields: u64,
    /// Time limit of a run (s).
    pub duration_secs: f64,
    /// The floors.
    pub floors: Vec<Floor>,
    /// The layout families.
    pub families: Vec<Family>,
    /// The passive-compliance sweep (kp, N·m/rad).
    pub passive_kp_nm_per_rad: Vec<f64>,
    /// Whether the built-in contact laws run (on estimated contacts).
    pub laws: bool,
    /// Whether they run on the true contacts too (for the estimated-against-true comparison).
    pub true_contacts: bool,
    /// Controllers plugged in.
    pub plugged: Vec<Plugged>,
    /// Fields whose paths are plotted (held-out indices, per floor and family).
    pub path_fields: u64,
    /// The position servos' kp (N·m/rad; kv = kp/100) of the contact laws' runs: `None` for the
    /// stiff servos of every run but the passive ones; a passive gain puts the laws on the same
    /// soft servos as that baseline (their feedback-off run is then the passive run).
    pub law_servo_kp_nm_per_rad: Option<f64>,
    /// Called with (runs done, runs in all) after every run (Python's
    /// `simserpent.oal_bench(progress=...)`).
    pub on_progress: Option<crate::run::ProgressCallback>,
}

impl Bench {
    /// The full benchmark: 20 tuning and 100 held-out fields per family, 60-s time limit (the
    /// base gait crosses the goal line of the bare default floor in about 55 s, 0.074 body
    /// lengths per cycle: a condition succeeds when it keeps about that pace among the pegs).
    pub fn full() -> Self {
        Self {
            tuning_fields: 20,
            held_out_fields: 100,
            duration_secs: 60.0,
            floors: vec![Floor::Isotropic, Floor::Anisotropic],
            families: vec![Family::Lattice, Family::Random],
            passive_kp_nm_per_rad: PASSIVE_KP_NM_PER_RAD.to_vec(),
            laws: true,
            true_contacts: true,
            plugged: Vec::new(),
            path_fields: 2,
            law_servo_kp_nm_per_rad: None,
            on_progress: None,
        }
    }

    /// The CI benchmark: 1 tuning and 2 held-out fields per family, 6-s runs, one passive gain.
    pub fn quick() -> Self {
        Self {
            tuning_fields: 1,
            held_out_fields: 2,
            duration_secs: 6.0,
            passive_kp_nm_per_rad: vec![5.0],
            path_fields: 1,
            ..Self::full()
        }
    }

    /// The conditions, in table order.
    pub fn conditions(&self) -> Vec<Condition> {
        let mut c = vec![Condition { name: "open_loop".into(), kind: Kind::OpenLoop }];
        for &kp in &self.passive_kp_nm_per_rad {
            c.push(Condition { name: format!("passive_kp{kp}"), kind: Kind::Passive(kp) });
        }
        if self.laws {
            for (name, kind) in LAWS {
                c.push(Condition { name: format!("{name}_est"), kind: Kind::Law(kind, ContactSource::Estimated) });
                if self.true_contacts {
                    c.push(Condition { name: format!("{name}_true"), kind: Kind::Law(kind, ContactSource::True) });
                }
            }
        }
        for p in &self.plugged {
            c.push(Condition { name: p.name.clone(), kind: Kind::Plugged(p.clone()) });
        }
        c
    }
}

/// The body's wavelength along the body (m): 360°/δ links.
pub fn body_wavelength_m(config: &Config) -> f64 {
    360.0 / BASE_PHASE_LAG_DEG * config.snake.link_length_m
}

/// A SplitMix64 step (the benchmark's one random stream: lattice offsets, bootstrap).
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn unit(state: &mut u64) -> f64 {
    (splitmix(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// The field config: floor, layout and seed on top of `base` (10 links, default sensors with
/// noise, estimation on, the base gait and servos, open loop).
pub fn field_config(base: &Config, floor: Floor, layout: Layout, seed: u64) -> Config {
    let ground = match floor {
        Floor::Isotropic => GroundModel::Isotropic,
        Floor::Anisotropic => Config::default().ground.model,
    };
    let mut c = super::estimation::peg_field_config(base, ground, seed, 1.0);
    c.ground = Config::default().ground;
    c.ground.model = ground;
    c.control.controller = ControllerKind::Gait;
    c.gait.kind = GaitKind::SineWave;
    c.gait.sine_wave.amplitude_deg = BASE_AMPLITUDE_DEG;
    c.gait.sine_wave.phase_lag_deg = BASE_PHASE_LAG_DEG;
    c.gait.sine_wave.frequency_hz = FREQUENCY_HZ;
    c.gait.sine_wave.offset_deg = 0.0;
    c.control.position_kp_nm_per_rad = SERVO_KP_NM_PER_RAD;
    c.control.position_kv_nm_s_per_rad = SERVO_KV_NM_S_PER_RAD;
    c.snake.torque_range_nm = [-TORQUE_LIMIT_NM, TORQUE_LIMIT_NM];
    let p = &mut c.terrain.pegboard;
    p.region_min_m = REGION_MIN_M;
    p.region_max_m = REGION_MAX_M;
    p.skip_pegs_on_snake = true;
    let lambda = body_wavelength_m(&c);
    let mut rng = seed ^ 0x5EED_0A1B_0000_0000;
    match layout {
        Layout::Square(s) | Layout::Hexagonal(s) => {
            let p = &mut c.terrain.pegboard;
            p.layout = if matches!(layout, Layout::Square(_)) { PegLayout::Square } else { PegLayout::Hexagonal };
            p.spacing_m = s * lambda;
            // A seeded shift of the lattice within one cell: a new field per seed.
            let (u, v) = (unit(&mut rng), unit(&mut rng));
            p.region_min_m = [REGION_MIN_M[0] + u * p.spacing_m, REGION_MIN_M[1] + v * p.spacing_m];
        }
        Layout::Random(density) => {
            let p = &mut c.terrain.pegboard;
            p.layout = PegLayout::Random;
            p.spacing_m = RANDOM_SPACING_M;
            let area = (REGION_MAX_M[0] - REGION_MIN_M[0]) * (REGION_MAX_M[1] - REGION_MIN_M[1]);
            p.count = (density * area).round() as usize;
        }
        Layout::Bare => c.terrain.pegboard.layout = PegLayout::None,
    }
    c
}

/// The body length of the benchmark's snake (m).
fn body_length_m(base: &Config) -> f64 {
    let c = field_config(base, Floor::Isotropic, Layout::Bare, 0);
    c.snake.n_links as f64 * c.snake.link_length_m
}

/// The gait's ramp-in (s).
fn base_ramp_secs(base: &Config) -> f64 {
    field_config(base, Floor::Isotropic, Layout::Bare, 0).gait.ramp_secs
}

/// The config of one condition on a field, and the controller to plug in (if any).
fn condition_config(field: &Config, condition: &Condition, bench: &Bench) -> Config {
    let mut c = field.clone();
    c.general.duration_secs = bench.duration_secs;
    c.estimation.enabled = false;
    match &condition.kind {
        Kind::OpenLoop => {}
        Kind::Passive(kp) => {
            c.control.position_kp_nm_per_rad = *kp;
            c.control.position_kv_nm_s_per_rad = kp / 100.0;
        }
        Kind::Law(kind, source) => {
            c.control.controller = *kind;
            c.follow_the_leader_reflex.contacts = *source;
            c.directional_admittance.contacts = *source;
            c.jam_resolution.contacts = *source;
            c.estimation.enabled = *source == ContactSource::Estimated;
            if let Some(kp) = bench.law_servo_kp_nm_per_rad {
                c.control.position_kp_nm_per_rad = kp;
                c.control.position_kv_nm_s_per_rad = kp / 100.0;
            }
        }
        Kind::Plugged(p) => c.estimation.enabled = p.estimation,
    }
    c
}

/// A run's outcome: its trace, or `None` when an interrupt stopped it.
type RunResult = Result<Option<Trace>, ExperimentError>;

/// Why a run's loop stopped early.
#[derive(Debug)]
enum Stop {
    Sim(SimError),
    Goal,
    Interrupted,
}

impl From<SimError> for Stop {
    fn from(e: SimError) -> Self {
        Stop::Sim(e)
    }
}

/// What a run records.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// Sample times (s) and centre of mass (m).
    pub time_secs: Vec<f64>,
    pub com_m: Vec<[f64; 2]>,
    /// Estimated and true total obstacle force on the body (sum over links of |f_xy|, N), when
    /// the run estimates contacts.
    pub estimated_n: Vec<f64>,
    pub true_n: Vec<f64>,
    goal_x_m: f64,
    body_m: f64,
    /// Whether the centre of mass reached the goal line.
    pub reached: bool,
}

impl Observer<Stop> for Trace {
    fn on_record(&mut self, view: &StepView<'_>, snap: &Snapshot) -> Result<(), Stop> {
        let com = snap.centre_of_mass_m();
        self.time_secs.push(snap.time_secs);
        self.com_m.push([com[0], com[1]]);
        let est = &view.observation.contacts;
        if est.active {
            self.estimated_n.push(est.obstacle_force_n.iter().map(|f| f[0].hypot(f[1])).sum());
            self.true_n.push(snap.link_obstacle_force_n.iter().map(|f| f[0].hypot(f[1])).sum());
        }
        if self.time_secs.len() == 1 {
            self.goal_x_m = com[0] + GOAL_BODY_LENGTHS * self.body_m;
        }
        if crate::interrupt::requested() {
            return Err(Stop::Interrupted);
        }
        if com[0] >= self.goal_x_m {
            self.reached = true;
            return Err(Stop::Goal);
        }
        Ok(())
    }
}

/// Runs `config` with `controller` (or the config's own) in memory; `None` when interrupted.
fn run_one(config: &Config, controller: Option<Box<dyn Controller>>) -> Result<Option<Trace>, ExperimentError> {
    config.validate().map_err(|e| RunError::Sim(e.into()))?;
    let world = World::from_config(config).map_err(RunError::Sim)?;
    let mut sim = match controller {
        Some(c) => Simulation::with_controller(config, world, c),
        None => Simulation::new(config, world),
    };
    let steps = (config.general.duration_secs / config.general.timestep_secs).round() as u64;
    let capacity = (steps / RECORD_EVERY + 2) as usize;
    let mut trace = Trace {
        time_secs: Vec::with_capacity(capacity),
        com_m: Vec::with_capacity(capacity),
        body_m: config.snake.n_links as f64 * config.snake.link_length_m,
        ..Trace::default()
    };
    match sim.run(LoopPlan { steps, record_every_n_steps: RECORD_EVERY }, &mut [&mut trace]) {
        Ok(()) | Err(Stop::Goal) => Ok(Some(trace)),
        Err(Stop::Interrupted) => Ok(None),
        Err(Stop::Sim(e)) => Err(RunError::Sim(e).into()),
    }
}

/// The scores of one run.
#[derive(Debug, Clone, Copy, Default)]
pub struct Score {
    /// Crossed the goal line.
    pub success: bool,
    /// When it stopped (s): at the goal line or the time limit.
    pub end_secs: f64,
    /// Jams per minute after the ramp-in.
    pub jams_per_min: f64,
    /// Body lengths per gait cycle after the ramp-in.
    pub speed_bl_per_cycle: f64,
    /// Direction of the motion over the last [`EXIT_WINDOW_SECS`] (degrees from +x).
    pub exit_heading_deg: f64,
    /// Relative error of the estimated total obstacle force (Σ|est − true| / Σ true; NaN
    /// without estimates or without contact).
    pub estimate_error: f64,
}

/// Number of jams of a path of (time (s), x (m)) samples after `from_secs`: windows of
/// [`JAM_WINDOW_SECS`] in which the farthest x reached grows by less than [`JAM_PROGRESS_M`];
/// after a jam the next window starts where it ended.
pub fn count_jams(path: &[(f64, f64)], from_secs: f64) -> usize {
    let mut best = Vec::with_capacity(path.len());
    let mut b = f64::NEG_INFINITY;
    for s in path {
        b = b.max(s.1);
        best.push(b);
    }
    let mut i = path.iter().position(|s| s.0 >= from_secs - 1e-9).unwrap_or(path.len());
    let mut jams = 0;
    let mut later = i;
    while i < path.len() {
        while later < path.len() && path[later].0 < path[i].0 + JAM_WINDOW_SECS - 1e-9 {
            later += 1;
        }
        if later >= path.len() {
            break;
        }
        if best[later] - best[i] < JAM_PROGRESS_M {
            jams += 1;
            i = later;
        } else {
            i += 1;
        }
        later = later.max(i);
    }
    jams
}

/// Scores a trace (ramp-in `ramp_secs`, gait frequency `frequency_hz`, body length `body_m`).
pub fn score(trace: &Trace, ramp_secs: f64, frequency_hz: f64, body_m: f64) -> Score {
    let n = trace.time_secs.len();
    if n < 2 {
        return Score { estimate_error: f64::NAN, ..Score::default() };
    }
    let path: Vec<(f64, f64)> = trace.time_secs.iter().zip(&trace.com_m).map(|(t, c)| (*t, c[0])).collect();
    let start = path.iter().position(|s| s.0 >= ramp_secs - 1e-9).unwrap_or(0).min(n - 1);
    let end_secs = trace.time_secs[n - 1];
    let span = end_secs - trace.time_secs[start];
    let advance = trace.com_m[n - 1][0] - trace.com_m[start][0];
    let speed = if span > 0.0 { advance / body_m / (frequency_hz * span) } else { 0.0 };
    let jams = count_jams(&path, ramp_secs);
    let minutes = span / 60.0;
    let exit_from = trace.time_secs.iter().position(|t| *t >= end_secs - EXIT_WINDOW_SECS - 1e-9).unwrap_or(0);
    let d = [trace.com_m[n - 1][0] - trace.com_m[exit_from][0], trace.com_m[n - 1][1] - trace.com_m[exit_from][1]];
    let truth: f64 = trace.true_n.iter().sum();
    let error: f64 = trace.estimated_n.iter().zip(&trace.true_n).map(|(e, t)| (e - t).abs()).sum();
    Score {
        success: trace.reached,
        end_secs,
        jams_per_min: if minutes > 0.0 { jams as f64 / minutes } else { 0.0 },
        speed_bl_per_cycle: speed,
        exit_heading_deg: d[1].atan2(d[0]).to_degrees(),
        estimate_error: if truth > 0.0 { error / truth } else { f64::NAN },
    }
}

/// The median of the finite values (NaN without any).
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

fn mean(values: &[f64]) -> f64 {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
}

/// A 90 % percentile-bootstrap interval of `statistic` over `values` (fields resampled with
/// replacement, [`RESAMPLES`] times, from a fixed-seed stream: the same values give the same
/// interval). NaN for no finite values.
pub fn bootstrap_interval(values: &[f64], statistic: fn(&[f64]) -> f64) -> (f64, f64) {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mut state: u64 = 0x0A1B_E5C4_2026_0031;
    let mut sample = vec![0.0; v.len()];
    let mut stats: Vec<f64> = (0..RESAMPLES)
        .map(|_| {
            for x in sample.iter_mut() {
                *x = v[(splitmix(&mut state) % v.len() as u64) as usize];
            }
            statistic(&sample)
        })
        .collect();
    stats.sort_by(f64::total_cmp);
    let at = |q: f64| stats[((q * (RESAMPLES - 1) as f64).round() as usize).min(RESAMPLES - 1)];
    (at(0.05), at(0.95))
}

/// "m (lo – hi)".
fn with_interval(values: &[f64], statistic: fn(&[f64]) -> f64, scale: f64) -> String {
    let (lo, hi) = bootstrap_interval(values, statistic);
    format!("{} ({} – {})", sig(scale * statistic(values)), sig(scale * lo), sig(scale * hi))
}

/// One run of the benchmark.
#[derive(Debug, Clone, Copy)]
struct Case {
    floor: usize,
    family: usize,
    seed: u64,
    held_out: bool,
    condition: usize,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Io { what: "write", path: path.to_path_buf(), source }
}

fn plot_error(e: crate::plot::PlotError) -> ExperimentError {
    ExperimentError::Data(format!("plot: {e}"))
}

/// The benchmark's outcome: the report section (tables and checks) and whether it was
/// interrupted (then the section holds what finished).
pub struct BenchOutcome {
    /// The report section.
    pub section: Section,
    /// Runs done and planned.
    pub runs_done: usize,
    pub runs_planned: usize,
    /// Held-out fields per family in the figures (fewer than planned after an interrupt).
    pub held_out_done: u64,
}

/// Runs the benchmark `bench` on top of `base` on `pool`, writing its tables and plots into
/// `folder`. Stops between runs (and within one, at the next record) when an interrupt is
/// requested ([`crate::interrupt`]): during the tuning fields with
/// [`ExperimentError::Interrupted`]; during the held-out fields with the tables and the section
/// of the held-out fields whose every run finished (a prefix of the seeds:
/// [`BenchOutcome::held_out_done`]), or `Interrupted` when there is none.
pub fn run_bench(
    bench: &Bench,
    base: &Config,
    pool: &rayon::ThreadPool,
    folder: &Path,
    progress: bool,
) -> Result<BenchOutcome, ExperimentError> {
    use rayon::prelude::*;
    let conditions = bench.conditions();
    let fields_of = |held_out: bool| -> Vec<(u64, bool)> {
        if held_out {
            (0..bench.held_out_fields).map(|s| (HELD_OUT_FIRST_SEED + s, true)).collect()
        } else {
            (0..bench.tuning_fields).map(|s| (s, false)).collect()
        }
    };
    // Phase 1: every condition (the whole passive sweep) on the tuning fields.
    let mut cases = Vec::new();
    for floor in 0..bench.floors.len() {
        for family in 0..bench.families.len() {
            for (seed, held_out) in fields_of(false) {
                for condition in 0..conditions.len() {
                    cases.push(Case { floor, family, seed, held_out, condition });
                }
            }
        }
    }
    let passive: Vec<usize> =
        (0..conditions.len()).filter(|&k| matches!(conditions[k].kind, Kind::Passive(_))).collect();
    // Phase 2 depends on the passive gain the tuning fields choose; its size is known up front.
    let held_out_conditions = conditions.len() - passive.len().saturating_sub(1);
    let total =
        cases.len() + bench.floors.len() * bench.families.len() * bench.held_out_fields as usize * held_out_conditions;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let cost = std::sync::Mutex::new(vec![(0usize, 0.0f64, 0.0f64); conditions.len()]);
    let run_case = |case: &Case| -> Result<Option<Trace>, ExperimentError> {
        if crate::interrupt::requested() {
            return Ok(None);
        }
        let family = bench.families[case.family];
        let index = if case.held_out { case.seed - HELD_OUT_FIRST_SEED } else { case.seed };
        let field = field_config(base, bench.floors[case.floor], Layout::of(family, index), case.seed);
        let condition = &conditions[case.condition];
        let config = condition_config(&field, condition, bench);
        let controller = match &condition.kind {
            Kind::Plugged(p) => Some((p.make)(&config, config.snake.n_links.saturating_sub(1))),
            _ => None,
        };
        let cpu_started = crate::cpu_time::thread_cpu_ns();
        let result = run_one(&config, controller);
        let cpu_secs = crate::cpu_time::thread_cpu_ns().saturating_sub(cpu_started) as f64 * 1e-9;
        if let Ok(Some(t)) = &result
            && let Ok(mut c) = cost.lock()
        {
            let e = &mut c[case.condition];
            *e = (e.0 + 1, e.1 + t.time_secs.last().copied().unwrap_or(0.0), e.2 + cpu_secs);
        }
        let n = done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
        if let Some(c) = &bench.on_progress {
            c.report(n as u64, total as u64);
        }
        if progress && (n.is_multiple_of(50) || n == total) {
            eprintln!("experiment oal-bench: {n} of {total} runs done");
        }
        result
    };
    // The cases in their order, each worker taking the next one: an interrupt leaves a finished
    // prefix (whole fields, in seed order), not scattered runs.
    let run_cases = |cases: &[Case]| -> Vec<Result<Option<Trace>, ExperimentError>> {
        let next = std::sync::atomic::AtomicUsize::new(0);
        let slots: Vec<std::sync::Mutex<Option<RunResult>>> =
            cases.iter().map(|_| std::sync::Mutex::new(None)).collect();
        pool.scope(|scope| {
            for _ in 0..pool.current_num_threads() {
                scope.spawn(|_| {
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                        let Some(case) = cases.get(i) else { break };
                        let result = run_case(case);
                        if let Ok(mut slot) = slots[i].lock() {
                            *slot = Some(result);
                        }
                    }
                });
            }
        });
        slots.into_iter().map(|s| s.into_inner().ok().flatten().unwrap_or(Ok(None))).collect()
    };
    // The bare floor once per floor: the base gait (what the pegs add) and the same gait on each
    // passive gain's soft servos (what softening alone does to the gait).
    let bare_conditions: Vec<usize> = std::iter::once(0).chain(passive.iter().copied()).collect();
    let bare_jobs: Vec<(usize, usize)> =
        (0..bench.floors.len()).flat_map(|fl| bare_conditions.iter().map(move |&k| (fl, k))).collect();
    let bare: Vec<Result<Option<Trace>, ExperimentError>> = pool.install(|| {
        bare_jobs
            .par_iter()
            .map(|&(fl, k)| {
                let field = field_config(base, bench.floors[fl], Layout::Bare, HELD_OUT_FIRST_SEED);
                let mut config = condition_config(&field, &conditions[k], bench);
                config.general.duration_secs = bench.duration_secs.min(30.0);
                run_one(&config, None)
            })
            .collect()
    });
    let mut results = run_cases(&cases);
    let tuning_done = results.iter().filter(|r| matches!(r, Ok(Some(_)))).count();
    if tuning_done < cases.len() && crate::interrupt::requested() {
        return Err(ExperimentError::Interrupted { done: tuning_done, planned: total });
    }
    let tuning_scores: Vec<Score> = results
        .iter()
        .map(|r| match r {
            Ok(Some(t)) => score(t, base_ramp_secs(base), FREQUENCY_HZ, body_length_m(base)),
            _ => Score::default(),
        })
        .collect();
    // The passive baseline per floor: the best tuning success rate over both families, then
    // median speed.
    let chosen_passive: Vec<Option<usize>> = (0..bench.floors.len())
        .map(|floor| {
            passive.iter().copied().max_by(|&a, &b| {
                let key = |k: usize| {
                    let (mut s, mut v) = (Vec::new(), Vec::new());
                    for (c, sc) in cases.iter().zip(&tuning_scores) {
                        if c.floor == floor && c.condition == k {
                            s.push(if sc.success { 1.0 } else { 0.0 });
                            v.push(sc.speed_bl_per_cycle);
                        }
                    }
                    (mean(&s), median(&v))
                };
                let (ka, kb) = (key(a), key(b));
                ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1)).then(b.cmp(&a))
            })
        })
        .collect();
    // Phase 2: the held-out fields, every condition but the passive gains not chosen.
    let tuning_cases = cases.len();
    // Field by field (every floor and family of a seed together), so an interrupt keeps whole
    // paired fields.
    for (seed, held_out) in fields_of(true) {
        for (floor, chosen) in chosen_passive.iter().enumerate() {
            for family in 0..bench.families.len() {
                for condition in 0..conditions.len() {
                    if passive.contains(&condition) && *chosen != Some(condition) {
                        continue;
                    }
                    cases.push(Case { floor, family, seed, held_out, condition });
                }
            }
        }
    }
    results.extend(run_cases(&cases[tuning_cases..]));
    if progress && let Ok(c) = cost.lock() {
        for (k, (runs, sim_secs, cpu_secs)) in c.iter().enumerate() {
            if *runs > 0 {
                eprintln!(
                    "experiment oal-bench: {}: {runs} runs, {:.1} simulated s per run, {:.2} CPU s per run ({:.0} µs per step)",
                    conditions[k].name,
                    sim_secs / *runs as f64,
                    cpu_secs / *runs as f64,
                    1e6 * cpu_secs / (sim_secs / base.general.timestep_secs).max(1.0),
                );
            }
        }
    }
    let total = cases.len();
    let mut traces = Vec::with_capacity(total);
    for r in results {
        traces.push(r?);
    }
    let bare: Vec<Option<Trace>> = bare.into_iter().collect::<Result<_, _>>()?;
    let runs_done = traces.iter().filter(|t| t.is_some()).count();
    // Interrupted during the held-out fields: the report covers the held-out seeds whose every
    // run finished (a prefix of the seeds), and says so.
    let mut held_out_done = bench.held_out_fields;
    if runs_done < total {
        let tuning_complete = traces[..tuning_cases].iter().all(Option::is_some);
        let complete = |seed: u64| cases.iter().zip(&traces).filter(|(c, _)| c.seed == seed).all(|(_, t)| t.is_some());
        held_out_done = (0..bench.held_out_fields).take_while(|&i| complete(HELD_OUT_FIRST_SEED + i)).count() as u64;
        if !tuning_complete || held_out_done == 0 || bare.iter().any(Option::is_none) {
            return Err(ExperimentError::Interrupted { done: runs_done, planned: total });
        }
        let keep: Vec<bool> =
            cases.iter().map(|c| !c.held_out || c.seed < HELD_OUT_FIRST_SEED + held_out_done).collect();
        let mut k = keep.iter();
        cases.retain(|_| *k.next().unwrap_or(&false));
        let mut k = keep.iter();
        traces.retain(|_| *k.next().unwrap_or(&false));
        // The signal stopped the runs; the tables and plots of the finished fields follow (a
        // second signal stops those too).
        crate::interrupt::clear();
    }
    let traces: Vec<Trace> = traces.into_iter().map(Option::unwrap_or_default).collect();
    let bare_all: Vec<Trace> = bare.into_iter().map(Option::unwrap_or_default).collect();
    // Per floor its bare runs in `bare_conditions` order: the base gait first.
    let bare_of_floor: Vec<&[Trace]> = bare_all.chunks(bare_conditions.len()).collect();
    let bare: Vec<&Trace> = bare_of_floor.iter().map(|runs| &runs[0]).collect();
    let reference = field_config(base, Floor::Isotropic, Layout::Bare, 0);
    let body_m = body_length_m(base);
    let ramp_secs = base_ramp_secs(base);
    let scores: Vec<Score> = traces.iter().map(|t| score(t, ramp_secs, FREQUENCY_HZ, body_m)).collect();

    // Per-run table.
    let runs_path = folder.join("oal_runs.csv");
    let mut csv = String::from(
        "floor,family,layout,seed,split,condition,success,end_s,jams_per_min,speed_bl_per_cycle,exit_heading_deg,estimate_error\n",
    );
    for (case, s) in cases.iter().zip(&scores) {
        let family = bench.families[case.family];
        let index = if case.held_out { case.seed - HELD_OUT_FIRST_SEED } else { case.seed };
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{}\n",
            bench.floors[case.floor].name(),
            family.name(),
            Layout::of(family, index).name(),
            case.seed,
            if case.held_out { "held_out" } else { "tuning" },
            conditions[case.condition].name,
            s.success,
            s.end_secs,
            s.jams_per_min,
            s.speed_bl_per_cycle,
            s.exit_heading_deg,
            s.estimate_error
        ));
    }
    std::fs::write(&runs_path, csv).map_err(io(&runs_path))?;

    // Values of one condition on one floor × family × split, in seed order (paired).
    let values = |floor: usize, family: usize, held_out: bool, condition: usize, f: fn(&Score) -> f64| -> Vec<f64> {
        cases
            .iter()
            .zip(&scores)
            .filter(|(c, _)| {
                c.floor == floor && c.family == family && c.held_out == held_out && c.condition == condition
            })
            .map(|(_, s)| f(s))
            .collect()
    };
    let success = |s: &Score| if s.success { 1.0 } else { 0.0 };
    let speed = |s: &Score| s.speed_bl_per_cycle;

    // The conditions of the held-out fields of a floor: every one but the passive gains not chosen.
    let shown =
        |floor: usize, k: usize| !matches!(conditions[k].kind, Kind::Passive(_)) || chosen_passive[floor] == Some(k);

    // Summary per floor × family × condition (held-out fields).
    let mut summary_rows = Vec::new();
    let mut summary_csv = String::from(
        "floor,family,condition,fields,success_rate,success_lo,success_hi,median_speed_bl_per_cycle,speed_lo,speed_hi,jams_per_min,exit_heading_q25_deg,exit_heading_median_deg,exit_heading_q75_deg,estimate_error_median\n",
    );
    for (fl, floor) in bench.floors.iter().enumerate() {
        for (fa, family) in bench.families.iter().enumerate() {
            for (k, condition) in conditions.iter().enumerate() {
                if !shown(fl, k) {
                    continue;
                }
                let s = values(fl, fa, true, k, success);
                let v = values(fl, fa, true, k, speed);
                let jams = values(fl, fa, true, k, |s| s.jams_per_min);
                let mut heading = values(fl, fa, true, k, |s| s.exit_heading_deg);
                heading.sort_by(f64::total_cmp);
                let q = |p: f64| {
                    if heading.is_empty() {
                        f64::NAN
                    } else {
                        heading[((p * (heading.len() - 1) as f64).round() as usize).min(heading.len() - 1)]
                    }
                };
                let err = median(&values(fl, fa, true, k, |s| s.estimate_error));
                let (slo, shi) = bootstrap_interval(&s, mean);
                let (vlo, vhi) = bootstrap_interval(&v, median);
                summary_csv.push_str(&format!(
                    "{},{},{},{},{},{slo},{shi},{},{vlo},{vhi},{},{},{},{},{err}\n",
                    floor.name(),
                    family.name(),
                    condition.name,
                    s.len(),
                    mean(&s),
                    median(&v),
                    mean(&jams),
                    q(0.25),
                    q(0.5),
                    q(0.75),
                ));
                let tag = if chosen_passive[fl] == Some(k) { " (passive baseline)" } else { "" };
                summary_rows.push(vec![
                    floor.name().to_string(),
                    family.name().to_string(),
                    format!("`{}`{tag}", condition.name),
                    s.len().to_string(),
                    with_interval(&s, mean, 100.0),
                    with_interval(&v, median, 1.0),
                    sig(mean(&jams)),
                    format!("{} / {} / {}", sig(q(0.25)), sig(q(0.5)), sig(q(0.75))),
                    if err.is_finite() { sig(err) } else { String::new() },
                ]);
            }
        }
    }
    let summary_path = folder.join("oal_summary.csv");
    std::fs::write(&summary_path, summary_csv).map_err(io(&summary_path))?;

    // Paired differences of every feedback condition against open loop and the passive
    // baseline, and estimated against true contacts.
    let mut paired_rows = Vec::new();
    let mut paired_csv = String::from("floor,family,condition,against,metric,mean_difference,lo,hi\n");
    let mut checks = Vec::new();
    let feedback: Vec<usize> =
        (0..conditions.len()).filter(|&k| matches!(conditions[k].kind, Kind::Law(..) | Kind::Plugged(_))).collect();
    let truth_of = |k: usize| -> Option<usize> {
        match conditions[k].kind {
            Kind::Law(kind, ContactSource::Estimated) => {
                conditions.iter().position(|c| matches!(c.kind, Kind::Law(other, ContactSource::True) if other == kind))
            }
            _ => None,
        }
    };
    for (fl, floor) in bench.floors.iter().enumerate() {
        for (fa, family) in bench.families.iter().enumerate() {
            for &k in &feedback {
                let mut against: Vec<(String, usize)> = vec![("open_loop".to_string(), 0)];
                if let Some(p) = chosen_passive[fl] {
                    against.push((conditions[p].name.clone(), p));
                }
                if let Some(t) = truth_of(k) {
                    against.push((conditions[t].name.clone(), t));
                }
                for (other_name, other) in against {
                    for (metric, f) in [("success", success as fn(&Score) -> f64), ("speed_bl_per_cycle", speed)] {
                        let a = values(fl, fa, true, k, f);
                        let b = values(fl, fa, true, other, f);
                        let d: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
                        let (lo, hi) = bootstrap_interval(&d, mean);
                        let m = mean(&d);
                        paired_csv.push_str(&format!(
                            "{},{},{},{other_name},{metric},{m},{lo},{hi}\n",
                            floor.name(),
                            family.name(),
                            conditions[k].name
                        ));
                        let scale = if metric == "success" { 100.0 } else { 1.0 };
                        paired_rows.push(vec![
                            floor.name().to_string(),
                            family.name().to_string(),
                            format!("`{}`", conditions[k].name),
                            format!("`{other_name}`"),
                            if metric == "success" { "success (points)".into() } else { "speed (BL/cycle)".into() },
                            format!("{} ({} – {})", sig(scale * m), sig(scale * lo), sig(scale * hi)),
                        ]);
                    }
                }
            }
        }
    }
    let paired_path = folder.join("oal_paired.csv");
    std::fs::write(&paired_path, paired_csv).map_err(io(&paired_path))?;

    // The checks: the isotropic floor gives the base gait no propulsion of its own; the target
    // (a contact law beats both baselines on success on every family, estimated contacts, with
    // the paired interval above 0).
    for (fl, floor) in bench.floors.iter().enumerate() {
        let s = score(bare[fl], ramp_secs, FREQUENCY_HZ, body_m);
        if *floor == Floor::Isotropic {
            checks.push(Check::at_most(
                "isotropic floor without pegs: the base gait's speed (≤ 0: every advance among pegs is peg-aided)",
                s.speed_bl_per_cycle,
                0.0,
                "BL/cycle",
            ));
        }
    }
    for &k in &feedback {
        if !matches!(conditions[k].kind, Kind::Law(_, ContactSource::Estimated) | Kind::Plugged(_)) {
            continue;
        }
        let mut worst = f64::INFINITY;
        for (fl, passive) in chosen_passive.iter().enumerate() {
            for fa in 0..bench.families.len() {
                let mut baselines = vec![0usize];
                baselines.extend(*passive);
                for other in baselines {
                    let a = values(fl, fa, true, k, success);
                    let b = values(fl, fa, true, other, success);
                    let d: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
                    worst = worst.min(bootstrap_interval(&d, mean).0);
                }
            }
        }
        checks.push(Check::at_least(
            &format!(
                "`{}`: lower 90 % bound of the paired success-rate gain over open loop and the passive baseline, worst floor × family (above 0 to beat both)",
                conditions[k].name
            ),
            100.0 * worst,
            0.01,
            "points",
        ));
    }

    // Plots.
    let plots = folder.join("plots");
    std::fs::create_dir_all(&plots).map_err(io(&plots))?;
    for (fl, floor) in bench.floors.iter().enumerate() {
        for (fa, family) in bench.families.iter().enumerate() {
            let (mut s, mut slo, mut shi, mut v, mut vlo, mut vhi) = (vec![], vec![], vec![], vec![], vec![], vec![]);
            let ks: Vec<usize> = (0..conditions.len()).filter(|&k| shown(fl, k)).collect();
            for &k in &ks {
                let ss = values(fl, fa, true, k, success);
                let (lo, hi) = bootstrap_interval(&ss, mean);
                s.push(100.0 * mean(&ss));
                slo.push(100.0 * lo);
                shi.push(100.0 * hi);
                let vv = values(fl, fa, true, k, speed);
                let (lo, hi) = bootstrap_interval(&vv, median);
                v.push(median(&vv));
                vlo.push(lo);
                vhi.push(hi);
            }
            let names: Vec<String> = ks.iter().map(|&k| conditions[k].name.clone()).collect();
            crate::plot::plot_intervals(
                &plots,
                &format!("oal_success_{}_{}", floor.name(), family.name()),
                &format!(
                    "{} floor, {} fields (held out): success rate with 90 % interval",
                    floor.name(),
                    family.name()
                ),
                "success (%)",
                &names,
                &s,
                &slo,
                &shi,
            )
            .map_err(plot_error)?;
            crate::plot::plot_intervals(
                &plots,
                &format!("oal_speed_{}_{}", floor.name(), family.name()),
                &format!(
                    "{} floor, {} fields (held out): median speed with 90 % interval",
                    floor.name(),
                    family.name()
                ),
                "speed (body lengths per cycle)",
                &names,
                &v,
                &vlo,
                &vhi,
            )
            .map_err(plot_error)?;
            // Paths over the first held-out fields.
            for index in 0..bench.path_fields.min(held_out_done) {
                let seed = HELD_OUT_FIRST_SEED + index;
                let layout = Layout::of(*family, index);
                let field = field_config(base, *floor, layout, seed);
                let pegs: Vec<([f64; 2], f64)> = crate::model::generate(&field)
                    .map_err(|e| ExperimentError::Data(format!("field {} seed {seed}: {e}", layout.name())))?
                    .obstacles
                    .iter()
                    .map(|c| (c.center_m, c.radius_m))
                    .collect();
                let paths: Vec<(String, Vec<f64>, Vec<f64>)> = cases
                    .iter()
                    .zip(&traces)
                    .filter(|(c, _)| c.floor == fl && c.family == fa && c.seed == seed)
                    .filter(|(c, _)| {
                        let name = &conditions[c.condition].name;
                        c.condition == 0 || chosen_passive[fl] == Some(c.condition) || name.ends_with("_est")
                    })
                    .map(|(c, t)| {
                        (
                            conditions[c.condition].name.clone(),
                            t.com_m.iter().map(|p| p[0]).collect(),
                            t.com_m.iter().map(|p| p[1]).collect(),
                        )
                    })
                    .collect();
                crate::plot::plot_paths_over_circles(
                    &plots,
                    &format!("oal_paths_{}_{}_{seed}", floor.name(), family.name()),
                    &format!("{} floor, {} (seed {seed}): centre-of-mass paths", floor.name(), layout.name()),
                    &paths,
                    &pegs,
                )
                .map_err(plot_error)?;
            }
            // The estimate against the truth on the first held-out field, per law.
            for (k, condition) in conditions.iter().enumerate() {
                if !matches!(condition.kind, Kind::Law(_, ContactSource::Estimated)) {
                    continue;
                }
                if let Some((_, t)) = cases
                    .iter()
                    .zip(&traces)
                    .find(|(c, _)| c.floor == fl && c.family == fa && c.seed == HELD_OUT_FIRST_SEED && c.condition == k)
                {
                    crate::plot::plot_time_series(
                        &plots,
                        &format!("oal_estimate_{}_{}_{}", condition.name, floor.name(), family.name()),
                        &format!(
                            "{}, {} floor, {} seed {HELD_OUT_FIRST_SEED}: obstacle force on the body (Σ|f_xy|)",
                            condition.name,
                            floor.name(),
                            family.name()
                        ),
                        "force (N)",
                        &t.time_secs,
                        &[("estimated".to_string(), t.estimated_n.clone()), ("true".to_string(), t.true_n.clone())],
                    )
                    .map_err(plot_error)?;
                }
            }
        }
    }

    let bare_text: Vec<String> = bench
        .floors
        .iter()
        .zip(&bare_of_floor)
        .map(|(f, runs)| {
            let speed = |t: &Trace| sig(score(t, ramp_secs, FREQUENCY_HZ, body_m).speed_bl_per_cycle);
            let soft: Vec<String> = bare_conditions[1..]
                .iter()
                .zip(&runs[1..])
                .map(|(&k, t)| format!("{} {}", conditions[k].name, speed(t)))
                .collect();
            let soft = if soft.is_empty() { String::new() } else { format!(" ({})", soft.join(", ")) };
            format!("{}: {} BL/cycle{soft}", f.name(), speed(&runs[0]))
        })
        .collect();
    let passive_text: Vec<String> = bench
        .floors
        .iter()
        .zip(&chosen_passive)
        .filter_map(|(f, p)| p.map(|p| format!("{}: `{}`", f.name(), conditions[p].name)))
        .collect();
    let lambda = body_wavelength_m(&reference);
    let section = Section {
        heading: "Obstacle-aided locomotion benchmark".into(),
        text: format!(
            "10 links ({link} m), base gait A = {BASE_AMPLITUDE_DEG}°, δ = {BASE_PHASE_LAG_DEG}° (toward the tail), \
             {FREQUENCY_HZ} Hz, position servos kp {SERVO_KP_NM_PER_RAD} N·m/rad, kv {SERVO_KV_NM_S_PER_RAD} N·m·s/rad, \
             ±{TORQUE_LIMIT_NM} N·m{law_servos}, default sensor noise. Floors: {floors}. Bare floor, base gait (and on the passive gains' servos): {bare}. \
             Layouts: lattice family (square and hexagonal, spacing λ/8, λ/6, λ/4 of λ = {lambda} m, shifted per seed), \
             random family ({densities} pegs/m², centres ≥ {RANDOM_SPACING_M} m apart), peg radius 0.05 m, centres in \
             x ∈ [{x0}, {x1}] m, y ∈ [{y0}, {y1}] m, none on the starting snake. Seeds: tuning 0..{nt}, held out \
             {h0}..{h1} per family (field i has layout i mod 6 (lattice) or i mod 3 (random)); every figure below and \
             every check is on the held-out fields; the passive-compliance gain is chosen on the tuning fields \
             ({passive}). Time limit {dur} s; success: the centre of mass crosses the line {GOAL_BODY_LENGTHS} body \
             lengths ({goal} m) ahead of its start. Jams: {JAM_WINDOW_SECS}-s windows after the {ramp}-s ramp-in with \
             less than {JAM_PROGRESS_M} m of new forward progress. Speed: body lengths per gait cycle after the ramp-in. \
             Exit heading: direction of the last {EXIT_WINDOW_SECS} s of motion (quartiles). Intervals: 90 % \
             percentile bootstrap over the fields ({RESAMPLES} resamples, fixed seed); paired differences are per \
             field. Files: oal_runs.csv, oal_summary.csv, oal_paired.csv, plots/ (oal_success_*, oal_speed_*, \
             oal_paths_*, oal_estimate_*).",
            link = reference.snake.link_length_m,
            law_servos = match bench.law_servo_kp_nm_per_rad {
                Some(kp) => format!(" (the contact laws on soft servos: kp {kp} N·m/rad, kv {} N·m·s/rad)", kp / 100.0),
                None => String::new(),
            },
            floors = bench.floors.iter().map(|f| f.name()).collect::<Vec<_>>().join(", "),
            bare = bare_text.join("; "),
            lambda = sig(lambda),
            densities = RANDOM_PEGS_PER_M2.map(sig).join(", "),
            x0 = REGION_MIN_M[0],
            x1 = REGION_MAX_M[0],
            y0 = REGION_MIN_M[1],
            y1 = REGION_MAX_M[1],
            nt = bench.tuning_fields,
            h0 = HELD_OUT_FIRST_SEED,
            h1 = HELD_OUT_FIRST_SEED + held_out_done,
            passive = if passive_text.is_empty() { "none swept".to_string() } else { passive_text.join("; ") },
            dur = bench.duration_secs,
            goal = GOAL_BODY_LENGTHS * body_m,
            ramp = ramp_secs,
        ),
        tables: vec![
            (
                [
                    "floor",
                    "family",
                    "condition",
                    "fields",
                    "success (%; 90 % interval)",
                    "median speed (BL/cycle; 90 % interval)",
                    "jams per min (mean)",
                    "exit heading (°; q25 / median / q75)",
                    "estimate error (median Σ‖est − true‖ / Σ true)",
                ]
                .map(String::from)
                .to_vec(),
                summary_rows,
            ),
            (
                ["floor", "family", "condition", "against", "metric", "mean paired difference (90 % interval)"]
                    .map(String::from)
                    .to_vec(),
                paired_rows,
            ),
        ],
        checks,
    };
    let mut section = section;
    if held_out_done < bench.held_out_fields {
        section.text.push_str(&format!(
            " **Stopped by an interrupt** after {held_out_done} of {} held-out fields per family: the figures \
             cover the held-out fields whose every run finished.",
            bench.held_out_fields
        ));
    }
    Ok(BenchOutcome { section, runs_done, runs_planned: total, held_out_done })
}

/// Runs `bench` into a new folder `<out>/oal-bench-<UTC time>/` and writes its `report.md`
/// there (`intro`: how it was started); returns the folder and the report.
pub fn run_into(
    bench: &Bench,
    base: &Config,
    pool: &rayon::ThreadPool,
    out: &Path,
    intro: &str,
    progress: bool,
) -> Result<(std::path::PathBuf, super::Report), ExperimentError> {
    let unix_secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let folder = crate::record::create_run_folder(out, "oal-bench", &crate::record::utc_stamp(unix_secs))
        .map_err(|e| ExperimentError::Run(RunError::Record(e)))?;
    let outcome = run_bench(bench, base, pool, &folder, progress)?;
    let report = super::Report {
        title: "SimSerpent obstacle-aided locomotion benchmark".into(),
        intro: format!("{intro}: {} runs.", outcome.runs_planned),
        sections: vec![outcome.section],
    };
    let path = folder.join("report.md");
    std::fs::write(&path, report.to_markdown()).map_err(io(&path))?;
    Ok((folder, report))
}

/// The experiment: [`Bench::quick`] or [`Bench::full`].
pub fn run(ctx: &super::Context, base: &Config) -> Result<Section, ExperimentError> {
    let bench = if ctx.quick { Bench::quick() } else { Bench::full() };
    let outcome = run_bench(&bench, base, &ctx.pool, &ctx.folder, ctx.progress)?;
    if outcome.held_out_done < bench.held_out_fields {
        // The command's contract on a signal: exit 130 with an incomplete report (the tables of
        // the finished fields are in the folder).
        return Err(ExperimentError::Interrupted { done: outcome.runs_done, planned: outcome.runs_planned });
    }
    Ok(outcome.section)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(xs: &[f64], dt: f64) -> Trace {
        Trace {
            time_secs: (0..xs.len()).map(|k| k as f64 * dt).collect(),
            com_m: xs.iter().map(|x| [*x, 0.0]).collect(),
            ..Trace::default()
        }
    }

    #[test]
    fn jams_are_counted_per_window_without_progress() {
        // 0.01 m/s: 0.05 m per 5 s, no jam.
        let moving: Vec<(f64, f64)> = (0..=300).map(|k| (0.1 * k as f64, 0.001 * k as f64)).collect();
        assert_eq!(count_jams(&moving, 1.0), 0);
        // Standing still for 30 s after the 1-s ramp: windows [1, 6], [6, 11], … [26, 31] → 5
        // whole windows end inside the path (the last one would end at 31 s > 30 s).
        let still: Vec<(f64, f64)> = (0..=300).map(|k| (0.1 * k as f64, 0.0)).collect();
        assert_eq!(count_jams(&still, 1.0), 5);
    }

    #[test]
    fn scores_of_a_straight_run() {
        // 0.1 m/s along +x for 20 s, 0.5 Hz, body 2 m: 0.1 BL/cycle, heading 0, no jam.
        let t = trace(&(0..=200).map(|k| 0.01 * k as f64).collect::<Vec<_>>(), 0.1);
        let s = score(&t, 2.0, 0.5, 2.0);
        assert!((s.speed_bl_per_cycle - 0.1).abs() < 1e-12, "{}", s.speed_bl_per_cycle);
        assert_eq!(s.jams_per_min, 0.0);
        assert!(s.exit_heading_deg.abs() < 1e-12);
        assert!(!s.success);
    }

    #[test]
    fn the_bootstrap_interval_is_repeatable_and_brackets_the_mean() {
        let v = [1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0];
        let (lo, hi) = bootstrap_interval(&v, mean);
        assert!(lo < 0.7 && 0.7 < hi, "{lo} {hi}");
        assert!(lo >= 0.0 && hi <= 1.0);
        assert_eq!(bootstrap_interval(&v, mean), (lo, hi));
        assert_eq!(bootstrap_interval(&[0.5; 4], mean), (0.5, 0.5));
    }

    #[test]
    fn layouts_cycle_through_each_family() {
        assert_eq!(Layout::of(Family::Lattice, 0), Layout::Square(1.0 / 8.0));
        assert_eq!(Layout::of(Family::Lattice, 5), Layout::Hexagonal(1.0 / 4.0));
        assert_eq!(Layout::of(Family::Random, 4), Layout::Random(3.0));
    }
}

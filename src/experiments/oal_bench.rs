//! Experiment `oal-bench`: the obstacle-aided locomotion benchmark (SPEC "How the field judges
//! obstacle-aided locomotion").
//!
//! A 10-link snake on SimSerpent's stick–slip floor runs one base gait, the lateral undulation
//! [`BASE_AMPLITUDE_DEG`]/[`BASE_PHASE_LAG_DEG`] (the wave travels toward the tail) at
//! [`FREQUENCY_HZ`] on the default position servos (kp [`SERVO_KP_NM_PER_RAD`]), chosen so that
//! its links never touch each other on the bare floor ([`bare_gait`] measures it, the report
//! checks it): every contact force a run feels is a peg's or a wall's. The conditions run on the
//! same fields (paired):
//!
//! - `open_loop`: the gait alone (feedback off; every contact law with `feedback = false` sends
//!   exactly these set-points);
//! - `passive_kp<k>`: the same open-loop gait on soft position servos (kp = k N·m/rad, kv =
//!   kp/100); the gain with the best tuning-field success rate (then distance) per floor is *the*
//!   passive-compliance baseline;
//! - `matched_kp<k>`: the stiff open loop at the frequency whose bare-floor speed equals passive
//!   kp k's (softer servos change the gait: a passive gain is compared with the stiff wave at
//!   equal bare-floor speed; [`match_frequency`]); on a floor where the base gait does not move
//!   forward there is nothing to match and every condition is scored against its twin instead;
//! - each contact law (`follow_the_leader_reflex`, `directional_admittance`, `jam_resolution`),
//!   fed the step loop's contact estimates (`_est`), the simulator's true obstacle contacts
//!   (`_true`) and, with [`Bench::true_with_self`], the true obstacle and self-contact forces as
//!   one (`_true_self`), its gains scaled by each of [`Bench::law_gain_scales`] on the tuning fields (the
//!   tuning budget: the same for every law and for a plugged controller's variants) and the best
//!   scale on the held-out fields;
//! - `compliance_g<G>` (with [`Bench::compliance`]): the base wave with Wang et al. (2023)'s
//!   generalised compliance G ([`crate::control::BilateralCompliance`]), a mechanical baseline
//!   without sensing, G swept on the tuning fields;
//! - `open_loop_heading` (with [`Bench::heading_gain`] above 0): the open loop with the heading
//!   hold ([`crate::control::HeadingHold`]) that every law then also has, the laws' baseline
//!   that steers like them;
//! - any controller a caller plugs in ([`Plugged`]).
//!
//! **Twins**: every held-out run also runs on the bare floor with the same seed (no pegs, the
//! same walls): the report gives each condition's peg effect (its distance minus its twin's)
//! beside the raw figures.
//!
//! **Floors**: `isotropic` (isotropic Coulomb friction: the base gait does not propel itself, so
//! every advance is peg-aided; goal [`goal_body_lengths`] = 1 body length) and `anisotropic`
//! (the default floor; goal 2 body lengths). **Layouts** in three families, all inside a channel
//! whose walls ([`WALL_Y_M`]) keep runs from leaving sideways: `lattice` (square and hexagonal
//! lattices, spacings [`LATTICE_SPACING_M`], shifted by a seeded offset per field), `random`
//! (uniform fields at [`RANDOM_PEGS_PER_M2`], centres ≥ 0.3 m apart) and `row` (a single row of
//! posts across the path [`ROW_X_M`] ahead of the head, spacings [`ROW_SPACING_M`], as in
//! Schiebel et al. 2019); field `seed` of a family has layout `seed mod (layouts of the family)`.
//! **Seeds**: tuning fields 0..n_tune, held-out fields from [`Bench::first_held_out_seed`].
//!
//! **Metrics** per run (Schiebel et al., PNAS 116 (2019) 4798; Wang et al. 2023): success (the
//! centre of mass crosses the goal line along +x within the time limit; the run stops there),
//! jam (the farthest forward position grows by less than [`JAM_PROGRESS_M`] in
//! [`JAM_WINDOW_SECS`] after the ramp-in: the run stops there, a failure), time to goal,
//! distance (forward advance of the centre of mass, body lengths), speed (body lengths per cycle
//! of the base gait after the ramp-in), heading change (the direction of motion over the last
//! [`EXIT_WINDOW_SECS`] against that over the first after the ramp-in: the scattering angle),
//! self-contact (the share of the recorded instants, every 50 steps from t = 0,
//! with a contact between two links, and the largest link–link force on one link: where the
//! body meets itself, the estimates read it as an obstacle). Per condition: success and jam
//! rates, medians with 90 % bootstrap intervals, heading-change quartiles and histogram,
//! self-contact (runs touching, mean share, largest force); paired differences against the
//! baselines with 90 % bootstrap intervals and McNemar's exact p for success.
//!
//! **Shards**: [`Bench::shard`] `(i, n)` runs every tuning case (the choices need them all) and
//! the held-out cases with index mod n = i, and writes `oal_runs-shard-i-of-n.csv`;
//! [`merge_shards`] joins the shards of one folder and writes the same tables as one unsharded
//! run, byte for byte.
//!
//! Files: `oal_runs.csv` (every run), `oal_summary.csv`, `oal_paired.csv`, `oal_heading.csv`,
//! `oal_bare.csv` (bare-floor calibration), `plots/`.

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
pub const BASE_AMPLITUDE_DEG: f64 = 40.0;
pub const BASE_PHASE_LAG_DEG: f64 = 36.0;
pub const FREQUENCY_HZ: f64 = 0.5;
/// Position servos of every run but the passive-compliance ones: the default config's (N·m/rad,
/// N·m·s/rad), and the benchmark's torque limit (N·m).
pub const SERVO_KP_NM_PER_RAD: f64 = 100.0;
pub const SERVO_KV_NM_S_PER_RAD: f64 = 1.0;
pub const TORQUE_LIMIT_NM: f64 = 10.0;
/// The passive-compliance sweep (position servo kp, N·m/rad; kv = kp/100).
pub const PASSIVE_KP_NM_PER_RAD: [f64; 3] = [10.0, 5.0, 2.5];
/// The generalised compliances of the `compliance` conditions (swept on the tuning fields).
pub const COMPLIANCE_G: [f64; 4] = [0.25, 0.5, 0.75, 1.0];
/// The law gain scales tried on the tuning fields.
pub const LAW_GAIN_SCALES: [f64; 3] = [0.5, 1.0, 2.0];
/// The jam rule: a run stops as jammed when its farthest forward position grows by less than
/// this in this window.
pub const JAM_WINDOW_SECS: f64 = 10.0;
pub const JAM_PROGRESS_M: f64 = 0.02;
/// Heading directions: the motion of the centre of mass over this stretch (s).
pub const EXIT_WINDOW_SECS: f64 = 4.0;
/// The first held-out seed of the default sizes; tuning seeds are 0..n_tune.
pub const HELD_OUT_FIRST_SEED: u64 = 1000;
/// Record the centre of mass every this many steps.
const RECORD_EVERY: u64 = 50;
/// Lattice spacings (m, centre to centre).
pub const LATTICE_SPACING_M: [f64; 3] = [0.5, 0.6, 0.7];
/// Random-field densities (pegs per m²) and the least centre distance (m).
pub const RANDOM_PEGS_PER_M2: [f64; 3] = [1.5, 3.0, 4.5];
const RANDOM_SPACING_M: f64 = 0.3;
/// The post row: its x (m; the head starts at x = 0) and its spacings (m, centre to centre).
pub const ROW_X_M: f64 = 0.5;
pub const ROW_SPACING_M: [f64; 3] = [0.3, 0.4, 0.5];
/// Peg centres lie in this rectangle (m); the snake starts with its head at the origin along +x.
const REGION_MIN_M: [f64; 2] = [-2.6, -1.6];
const REGION_MAX_M: [f64; 2] = [5.0, 1.6];
/// The channel's walls: inner faces at y = ±this (m), from x = −3 m to +6 m.
pub const WALL_Y_M: f64 = 1.8;
/// Bootstrap resamples of every interval.
const RESAMPLES: usize = 2000;
/// Bare-floor calibration runs (s): the base gait's link–link contact, the matched frequencies.
const CALIBRATION_SECS: f64 = 30.0;

/// The goal line of a floor, in body lengths ahead of the starting centre of mass: 2 on the
/// anisotropic floor, 1 on the isotropic one (where only pegs propel the body).
pub fn goal_body_lengths(floor: Floor) -> f64 {
    match floor {
        Floor::Isotropic => 1.0,
        Floor::Anisotropic => 2.0,
    }
}

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
    /// A single row of posts across the path at three spacings.
    Row,
}

impl Family {
    /// The family named `name` ("lattice", "random", "row").
    pub fn from_name(name: &str) -> Option<Family> {
        [Family::Lattice, Family::Random, Family::Row].into_iter().find(|f| f.name() == name)
    }

    /// Its name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Family::Lattice => "lattice",
            Family::Random => "random",
            Family::Row => "row",
        }
    }
}

/// One obstacle layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Layout {
    /// A square lattice, spacing (m).
    Square(f64),
    /// A hexagonal lattice, spacing (m).
    Hexagonal(f64),
    /// A random field, pegs per m².
    Random(f64),
    /// A single row of posts across the path, spacing (m).
    Row(f64),
    /// No pegs (the bare floor; the walls stay).
    Bare,
}

impl Layout {
    /// The layout of field `seed` of `family`.
    pub fn of(family: Family, seed: u64) -> Layout {
        match family {
            Family::Lattice => {
                let k = (seed % 6) as usize;
                let s = LATTICE_SPACING_M[k / 2];
                if k.is_multiple_of(2) { Layout::Square(s) } else { Layout::Hexagonal(s) }
            }
            Family::Random => Layout::Random(RANDOM_PEGS_PER_M2[(seed % 3) as usize]),
            Family::Row => Layout::Row(ROW_SPACING_M[(seed % 3) as usize]),
        }
    }

    /// A short name ("square 0.5 m", "random 3 /m²", "row 0.4 m").
    pub fn name(self) -> String {
        match self {
            Layout::Square(s) => format!("square {} m", sig(s)),
            Layout::Hexagonal(s) => format!("hexagonal {} m", sig(s)),
            Layout::Random(d) => format!("random {} /m²", sig(d)),
            Layout::Row(s) => format!("row {} m", sig(s)),
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
    /// The stiff open loop at the frequency matched to this passive gain's bare-floor speed.
    Matched(f64),
    /// A law, its contact feed and its gain scale.
    Law(ControllerKind, ContactSource, f64),
    /// The open loop with the laws' heading hold ([`Bench::heading_gain`]): the baseline of
    /// laws that steer.
    HeadingHold,
    /// The base wave with generalised compliance G ([`crate::control::BilateralCompliance`]).
    Compliance(f64),
    Plugged(Plugged),
}

/// A condition: name, what it runs, and the group of alternatives the tuning fields choose
/// among (one member of each group runs on the held-out fields).
#[derive(Clone)]
pub struct Condition {
    name: String,
    kind: Kind,
    group: String,
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
    /// Held-out fields per family (seeds from [`Bench::first_held_out_seed`]).
    pub held_out_fields: u64,
    /// The first held-out seed (at least `tuning_fields`: the two sets are disjoint).
    pub first_held_out_seed: u64,
    /// Time limit of a run (s).
    pub duration_secs: f64,
    /// The floors.
    pub floors: Vec<Floor>,
    /// The layout families.
    pub families: Vec<Family>,
    /// The passive-compliance sweep (kp, N·m/rad).
    pub passive_kp_nm_per_rad: Vec<f64>,
    /// Whether the stiff open loop also runs at each passive gain's bare-floor speed.
    pub speed_matched: bool,
    /// Generalised compliances G swept on the tuning fields (Wang et al. 2023's mechanical
    /// baseline, `compliance_g<G>`); empty: none.
    pub compliance: Vec<f64>,
    /// Whether the built-in contact laws run (on estimated contacts).
    pub laws: bool,
    /// Whether they run on the true contacts too (for the estimated-against-true comparison).
    pub true_contacts: bool,
    /// Whether they also run on the true obstacle and self-contact forces as one
    /// (`_true_self`: what an exact estimator blind to self-contacts would give).
    pub true_with_self: bool,
    /// The tuning budget of each law: its gains (every gain of its section that sets how
    /// strongly it reacts) times each of these on the tuning fields; `[1.0]`: untuned.
    pub law_gain_scales: Vec<f64>,
    /// Whether every held-out run has a bare-floor twin (same seed, no pegs).
    pub twins: bool,
    /// Controllers plugged in.
    pub plugged: Vec<Plugged>,
    /// Fields whose paths are plotted (the first held-out seeds, per floor and family).
    pub path_fields: u64,
    /// The position servos' kp (N·m/rad; kv = kp/100) of the contact laws' runs: `None` for the
    /// stiff servos of every run but the passive ones; a passive gain puts the laws on the same
    /// soft servos as that baseline (their feedback-off run is then the passive run).
    pub law_servo_kp_nm_per_rad: Option<f64>,
    /// The heading hold of every law ([`crate::control::HeadingHold`]; gait offset per radian
    /// of mean-heading error): 0 = off; above 0 each law steers its mean heading to the goal
    /// with this gain (at most [`HEADING_MAX_OFFSET_DEG`]), and the condition
    /// `open_loop_heading`, the open loop with the same term, is their baseline.
    pub heading_gain: f64,
    /// Run one shard `(i, n)`: every tuning case, the held-out cases with index mod n = i.
    pub shard: Option<(usize, usize)>,
    /// Called with (runs done, runs in all) after every run (Python's
    /// `simserpent.oal_bench(progress=...)`).
    pub on_progress: Option<crate::run::ProgressCallback>,
}

impl Bench {
    /// The full benchmark: 10 tuning and 30 held-out fields per family on both floors and the
    /// lattice and random families, 60-s runs, every condition with twins (its size in runs:
    /// BENCHMARKS.md).
    pub fn full() -> Self {
        Self {
            tuning_fields: 10,
            held_out_fields: 30,
            first_held_out_seed: HELD_OUT_FIRST_SEED,
            duration_secs: 60.0,
            floors: vec![Floor::Isotropic, Floor::Anisotropic],
            families: vec![Family::Lattice, Family::Random],
            passive_kp_nm_per_rad: PASSIVE_KP_NM_PER_RAD.to_vec(),
            speed_matched: true,
            compliance: Vec::new(),
            laws: true,
            true_contacts: true,
            true_with_self: false,
            law_gain_scales: LAW_GAIN_SCALES.to_vec(),
            twins: true,
            plugged: Vec::new(),
            path_fields: 2,
            law_servo_kp_nm_per_rad: None,
            heading_gain: 0.0,
            shard: None,
            on_progress: None,
        }
    }

    /// The CI benchmark: 1 tuning and 2 held-out fields per family, 6-s runs, one passive gain,
    /// untuned laws.
    pub fn quick() -> Self {
        Self {
            tuning_fields: 1,
            held_out_fields: 2,
            duration_secs: 6.0,
            passive_kp_nm_per_rad: vec![5.0],
            law_gain_scales: vec![1.0],
            path_fields: 1,
            ..Self::full()
        }
    }

    /// The held-out seeds.
    pub fn held_out_seeds(&self) -> Vec<u64> {
        (0..self.held_out_fields).map(|i| self.first_held_out_seed + i).collect()
    }

    /// Most tuning fields per family (seeds 0 to 999).
    pub const MAX_TUNING_FIELDS: u64 = 1_000;
    /// Most held-out fields per family.
    pub const MAX_HELD_OUT_FIELDS: u64 = 10_000;

    /// Checks the sizes before any field is planned: a clear message naming the size, its value
    /// and what is allowed (at most [`Bench::MAX_TUNING_FIELDS`] tuning and
    /// [`Bench::MAX_HELD_OUT_FIELDS`] held-out fields per family, held-out seeds after the tuning
    /// seeds, a time limit of 2 to 3600 s, at least one floor and one family).
    ///
    /// # Errors
    /// [`ExperimentError::Option`] naming the size, its value and what is allowed.
    pub fn check(&self) -> Result<(), ExperimentError> {
        let bad = |what: &str, value: String, allowed: String| {
            Err(ExperimentError::Option(format!("oal-bench {what} = {value}: {allowed}")))
        };
        if self.tuning_fields > Self::MAX_TUNING_FIELDS {
            let allowed = format!("give 0 to {} per family", Self::MAX_TUNING_FIELDS);
            return bad("tuning fields", self.tuning_fields.to_string(), allowed);
        }
        if !(1..=Self::MAX_HELD_OUT_FIELDS).contains(&self.held_out_fields) {
            let allowed = format!("give 1 to {} per family", Self::MAX_HELD_OUT_FIELDS);
            return bad("held-out fields", self.held_out_fields.to_string(), allowed);
        }
        if self.first_held_out_seed.checked_add(self.held_out_fields).is_none() {
            let allowed = "the last held-out seed must not pass 2^64 - 1".to_string();
            return bad("first held-out seed", self.first_held_out_seed.to_string(), allowed);
        }
        if self.first_held_out_seed < self.tuning_fields {
            let allowed = format!(
                "held-out seeds must start at {} or later, after the tuning seeds 0..{}",
                self.tuning_fields, self.tuning_fields
            );
            return bad("first held-out seed", self.first_held_out_seed.to_string(), allowed);
        }
        if !(self.duration_secs.is_finite() && (2.0..=3600.0).contains(&self.duration_secs)) {
            return bad("duration", format!("{} s", self.duration_secs), "give 2 to 3600 s".into());
        }
        if self.floors.is_empty() || self.families.is_empty() {
            let allowed = "give at least one floor and one family".to_string();
            return bad("floors and families", "none".into(), allowed);
        }
        if self.passive_kp_nm_per_rad.iter().any(|k| !(k.is_finite() && *k > 0.0)) {
            let value = format!("{:?}", self.passive_kp_nm_per_rad);
            return bad("passive gains", value, "every gain positive and finite".into());
        }
        if self.compliance.iter().any(|g| !(0.0..=1.0).contains(g)) {
            return bad("compliances", format!("{:?}", self.compliance), "each G from 0 to 1".into());
        }
        if self.law_gain_scales.is_empty() || self.law_gain_scales.iter().any(|k| !(k.is_finite() && *k > 0.0)) {
            let value = format!("{:?}", self.law_gain_scales);
            return bad("law gain scales", value, "at least one, each positive and finite".into());
        }
        if !(self.heading_gain.is_finite() && (0.0..=10.0).contains(&self.heading_gain)) {
            return bad("heading gain", self.heading_gain.to_string(), "give 0 (off) to 10".into());
        }
        if let Some((i, n)) = self.shard
            && (n == 0 || i >= n)
        {
            return bad("shard", format!("{i}/{n}"), "give i/n with 0 <= i < n".into());
        }
        Ok(())
    }

    /// The conditions, in table order.
    pub fn conditions(&self) -> Vec<Condition> {
        let one = |name: String, kind: Kind| Condition { group: name.clone(), name, kind };
        let mut c = vec![one("open_loop".into(), Kind::OpenLoop)];
        for &kp in &self.passive_kp_nm_per_rad {
            c.push(Condition { name: format!("passive_kp{kp}"), kind: Kind::Passive(kp), group: "passive".into() });
        }
        if self.speed_matched {
            for &kp in &self.passive_kp_nm_per_rad {
                c.push(Condition { name: format!("matched_kp{kp}"), kind: Kind::Matched(kp), group: "matched".into() });
            }
        }
        if self.heading_gain > 0.0 && self.laws {
            c.push(one("open_loop_heading".into(), Kind::HeadingHold));
        }
        for &g in &self.compliance {
            c.push(Condition {
                name: format!("compliance_g{g}"),
                kind: Kind::Compliance(g),
                group: "compliance".into(),
            });
        }
        if self.laws {
            let mut sources = vec![("est", ContactSource::Estimated)];
            if self.true_contacts {
                sources.push(("true", ContactSource::True));
            }
            if self.true_with_self {
                sources.push(("true_self", ContactSource::TrueWithSelf));
            }
            for (name, kind) in LAWS {
                for &(tag, source) in &sources {
                    let group = format!("{name}_{tag}");
                    for &g in &self.law_gain_scales {
                        let name =
                            if self.law_gain_scales.len() == 1 { group.clone() } else { format!("{group}_g{g}") };
                        c.push(Condition { name, kind: Kind::Law(kind, source, g), group: group.clone() });
                    }
                }
            }
        }
        for p in &self.plugged {
            c.push(one(p.name.clone(), Kind::Plugged(p.clone())));
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
/// noise, estimation on, the base gait and servos, open loop, the channel's walls).
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
    let ch = &mut c.terrain.channel;
    ch.enabled = true;
    ch.start_m = [REGION_MIN_M[0] - 0.4, 0.0];
    ch.end_m = [REGION_MAX_M[0] + 1.0, 0.0];
    ch.width_m = 2.0 * WALL_Y_M;
    ch.height_m = 0.2;
    ch.thickness_m = 0.1;
    let p = &mut c.terrain.pegboard;
    p.region_min_m = REGION_MIN_M;
    p.region_max_m = REGION_MAX_M;
    p.skip_pegs_on_snake = true;
    let mut rng = seed ^ 0x5EED_0A1B_0000_0000;
    match layout {
        Layout::Square(s) | Layout::Hexagonal(s) => {
            p.layout = if matches!(layout, Layout::Square(_)) { PegLayout::Square } else { PegLayout::Hexagonal };
            p.spacing_m = s;
            // A seeded shift of the lattice within one cell: a new field per seed.
            let (u, v) = (unit(&mut rng), unit(&mut rng));
            p.region_min_m = [REGION_MIN_M[0] + u * s, REGION_MIN_M[1] + v * s];
        }
        Layout::Random(density) => {
            p.layout = PegLayout::Random;
            p.spacing_m = RANDOM_SPACING_M;
            let area = (REGION_MAX_M[0] - REGION_MIN_M[0]) * (REGION_MAX_M[1] - REGION_MIN_M[1]);
            p.count = (density * area).round() as usize;
        }
        Layout::Row(s) => {
            // One column of a square lattice at x = ROW_X_M, shifted along y per seed.
            p.layout = PegLayout::Square;
            p.spacing_m = s;
            let v = unit(&mut rng);
            p.region_min_m = [ROW_X_M, REGION_MIN_M[1] + v * s];
            p.region_max_m = [ROW_X_M, REGION_MAX_M[1]];
        }
        Layout::Bare => p.layout = PegLayout::None,
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

/// Scales the gains of a law's section by `g`: how strongly it reacts to contacts.
fn scale_law_gains(c: &mut Config, kind: ControllerKind, g: f64) {
    match kind {
        ControllerKind::FollowTheLeaderReflex => {
            let r = &mut c.follow_the_leader_reflex;
            r.propulsive_gain_rad_per_n *= g;
            r.resisting_gain_rad_per_n *= g;
        }
        ControllerKind::DirectionalAdmittance => {
            // Compliance 1/K (and the damping with it: the same time constant).
            let a = &mut c.directional_admittance;
            a.stiffness_nm_per_rad /= g;
            a.damping_nm_s_per_rad /= g;
        }
        ControllerKind::JamResolution => {
            let j = &mut c.jam_resolution;
            j.push_force_n *= g;
            j.max_offset_deg = (j.max_offset_deg * g).min(c.snake.joint_range_deg);
        }
        _ => {}
    }
}

/// Largest gait offset of the laws' heading hold in the benchmark (degrees).
pub const HEADING_MAX_OFFSET_DEG: f64 = 10.0;

/// Puts every law's heading hold at `gain` (0: off), at most [`HEADING_MAX_OFFSET_DEG`].
fn set_heading_hold(c: &mut Config, gain: f64) {
    for (g, max) in [
        (&mut c.follow_the_leader_reflex.heading_gain, &mut c.follow_the_leader_reflex.heading_max_offset_deg),
        (&mut c.directional_admittance.heading_gain, &mut c.directional_admittance.heading_max_offset_deg),
        (&mut c.jam_resolution.heading_gain, &mut c.jam_resolution.heading_max_offset_deg),
    ] {
        *g = gain;
        *max = HEADING_MAX_OFFSET_DEG;
    }
}

/// The config of one condition on a field (`matched_hz`: the matched frequency of a `Matched`
/// condition on this floor).
fn condition_config(field: &Config, condition: &Condition, bench: &Bench, matched_hz: Option<f64>) -> Config {
    let mut c = field.clone();
    c.general.duration_secs = bench.duration_secs;
    c.estimation.enabled = false;
    match &condition.kind {
        Kind::OpenLoop => {}
        Kind::Passive(kp) => {
            c.control.position_kp_nm_per_rad = *kp;
            c.control.position_kv_nm_s_per_rad = kp / 100.0;
        }
        Kind::Matched(_) => {
            if let Some(f) = matched_hz {
                c.gait.sine_wave.frequency_hz = f;
            }
        }
        Kind::Law(kind, source, g) => {
            c.control.controller = *kind;
            c.follow_the_leader_reflex.contacts = *source;
            c.directional_admittance.contacts = *source;
            c.jam_resolution.contacts = *source;
            c.estimation.enabled = *source == ContactSource::Estimated;
            scale_law_gains(&mut c, *kind, *g);
            set_heading_hold(&mut c, bench.heading_gain);
            if let Some(kp) = bench.law_servo_kp_nm_per_rad {
                c.control.position_kp_nm_per_rad = kp;
                c.control.position_kv_nm_s_per_rad = kp / 100.0;
            }
        }
        Kind::HeadingHold => {
            // A law without its contact terms is the open loop bit for bit; its heading hold
            // stays.
            c.control.controller = ControllerKind::FollowTheLeaderReflex;
            c.follow_the_leader_reflex.feedback = false;
            // No contact is read (feedback off): no estimator to run.
            c.follow_the_leader_reflex.contacts = ContactSource::True;
            set_heading_hold(&mut c, bench.heading_gain);
            if let Some(kp) = bench.law_servo_kp_nm_per_rad {
                c.control.position_kp_nm_per_rad = kp;
                c.control.position_kv_nm_s_per_rad = kp / 100.0;
            }
        }
        Kind::Compliance(_) | Kind::Plugged(_) => {
            if let Kind::Plugged(p) = &condition.kind {
                c.estimation.enabled = p.estimation;
            }
        }
    }
    c
}

/// How a gait meets its own body on the bare floor: what [`bare_gait`] measures.
#[derive(Debug, Clone, Copy, Default)]
pub struct BareGait {
    /// Share of the steps (the whole run from t = 0) with a contact between two links.
    pub self_contact_share: f64,
    /// Largest total link–link contact force on one link (N).
    pub max_self_contact_n: f64,
    /// Largest joint angle reached after the ramp-in (degrees).
    pub amplitude_reached_deg: f64,
    /// Speed along +x after the ramp-in (body lengths per cycle).
    pub speed_bl_per_cycle: f64,
    /// Share of the link-steps after the ramp-in on which the contact estimates flag an obstacle
    /// (false alarms: there is none); NaN without estimates.
    pub estimate_flag_share: f64,
}

/// The largest total link–link contact force on one link at `snap` (N; 0 when no two links touch).
fn largest_self_contact_n(snap: &Snapshot) -> f64 {
    snap.link_self_contact_force_n.iter().map(|f| (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt()).fold(0.0, f64::max)
}

/// Counts link–link contacts at every instant.
#[derive(Default)]
struct SelfContacts {
    after_secs: f64,
    steps: usize,
    touching: usize,
    max_n: f64,
    max_angle_rad: f64,
    link_steps: usize,
    flags: usize,
}

impl Observer<SimError> for SelfContacts {
    fn on_record(&mut self, view: &StepView<'_>, snap: &Snapshot) -> Result<(), SimError> {
        // Link–link contact over the whole run from t = 0.
        self.steps += 1;
        let most = largest_self_contact_n(snap);
        if most > 0.0 {
            self.touching += 1;
        }
        self.max_n = self.max_n.max(most);
        if snap.time_secs < self.after_secs - 1e-9 {
            return Ok(());
        }
        self.max_angle_rad = snap.joint_angle_rad.iter().fold(self.max_angle_rad, |m, a| m.max(a.abs()));
        let est = &view.observation.contacts;
        if est.active {
            self.link_steps += est.contact.len();
            self.flags += est.contact.iter().filter(|c| **c).count();
        }
        Ok(())
    }
}

/// Runs `config` (a bare-floor config) for `duration_secs` recording every step, and measures
/// its link–link contacts (from t = 0), its speed after the ramp-in and (with `[estimation]` on) the share of
/// link-steps its estimates flag.
pub fn bare_gait(config: &Config, duration_secs: f64) -> Result<BareGait, ExperimentError> {
    let mut c = config.clone();
    c.general.duration_secs = duration_secs;
    c.validate().map_err(|e| RunError::Sim(e.into()))?;
    let world = World::from_config(&c).map_err(RunError::Sim)?;
    let mut sim = Simulation::new(&c, world);
    let steps = (duration_secs / c.general.timestep_secs).round() as u64;
    let ramp = c.gait.ramp_secs;
    let mut counts = SelfContacts { after_secs: ramp, ..SelfContacts::default() };
    let mut path = Vec::new();
    struct Com<'a>(&'a mut Vec<(f64, f64)>);
    impl Observer<SimError> for Com<'_> {
        fn on_record(&mut self, _: &StepView<'_>, snap: &Snapshot) -> Result<(), SimError> {
            self.0.push((snap.time_secs, snap.centre_of_mass_m()[0]));
            Ok(())
        }
    }
    sim.run(LoopPlan { steps, record_every_n_steps: 1 }, &mut [&mut counts, &mut Com(&mut path)])
        .map_err(RunError::Sim)?;
    let body_m = c.snake.n_links as f64 * c.snake.link_length_m;
    let start = path.iter().position(|s| s.0 >= ramp - 1e-9).unwrap_or(0);
    let (t0, x0) = path[start];
    let (t1, x1) = path[path.len() - 1];
    let share = |a: usize, b: usize| if b > 0 { a as f64 / b as f64 } else { f64::NAN };
    Ok(BareGait {
        self_contact_share: share(counts.touching, counts.steps),
        max_self_contact_n: counts.max_n,
        amplitude_reached_deg: counts.max_angle_rad.to_degrees(),
        speed_bl_per_cycle: if t1 > t0 {
            (x1 - x0) / body_m / (c.gait.sine_wave.frequency_hz * (t1 - t0))
        } else {
            0.0
        },
        estimate_flag_share: share(counts.flags, counts.link_steps),
    })
}

/// A run's outcome: its trace, or `None` when an interrupt stopped it.
type RunResult = Result<Option<Trace>, ExperimentError>;

/// Why a run's loop stopped early.
#[derive(Debug)]
enum Stop {
    Sim(SimError),
    Goal,
    Jam,
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
    goal_body_lengths: f64,
    body_m: f64,
    ramp_secs: f64,
    /// The jam rule's state: farthest x and when it last grew by the jam progress.
    best_x_m: f64,
    anchor: (f64, f64),
    /// Whether the centre of mass reached the goal line.
    pub reached: bool,
    /// Whether the run stopped jammed.
    pub jammed: bool,
    /// Recorded instants with a contact between two links, and the largest link–link contact
    /// force on one link (N).
    pub self_touching: usize,
    pub max_self_contact_n: f64,
}

impl Observer<Stop> for Trace {
    fn on_record(&mut self, view: &StepView<'_>, snap: &Snapshot) -> Result<(), Stop> {
        let com = snap.centre_of_mass_m();
        let t = snap.time_secs;
        self.time_secs.push(t);
        self.com_m.push([com[0], com[1]]);
        let most = largest_self_contact_n(snap);
        if most > 0.0 {
            self.self_touching += 1;
        }
        self.max_self_contact_n = self.max_self_contact_n.max(most);
        let est = &view.observation.contacts;
        if est.active {
            self.estimated_n.push(est.obstacle_force_n.iter().map(|f| f[0].hypot(f[1])).sum());
            self.true_n.push(snap.link_obstacle_force_n.iter().map(|f| f[0].hypot(f[1])).sum());
        }
        if self.time_secs.len() == 1 {
            self.goal_x_m = com[0] + self.goal_body_lengths * self.body_m;
            self.best_x_m = com[0];
        }
        if crate::interrupt::requested() {
            return Err(Stop::Interrupted);
        }
        if com[0] >= self.goal_x_m {
            self.reached = true;
            return Err(Stop::Goal);
        }
        // The jam rule, from the end of the ramp-in.
        self.best_x_m = self.best_x_m.max(com[0]);
        if t < self.ramp_secs - 1e-9 || self.best_x_m >= self.anchor.1 + JAM_PROGRESS_M {
            self.anchor = (t, self.best_x_m);
        } else if t - self.anchor.0 >= JAM_WINDOW_SECS - 1e-9 {
            self.jammed = true;
            return Err(Stop::Jam);
        }
        Ok(())
    }
}

/// Runs `config` with `controller` (or the config's own) in memory on `floor`; `None` when
/// interrupted.
fn run_one(
    config: &Config,
    floor: Floor,
    controller: Option<Box<dyn Controller>>,
) -> Result<Option<Trace>, ExperimentError> {
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
        goal_body_lengths: goal_body_lengths(floor),
        ramp_secs: config.gait.ramp_secs,
        ..Trace::default()
    };
    match sim.run(LoopPlan { steps, record_every_n_steps: RECORD_EVERY }, &mut [&mut trace]) {
        Ok(()) | Err(Stop::Goal) | Err(Stop::Jam) => Ok(Some(trace)),
        Err(Stop::Interrupted) => Ok(None),
        Err(Stop::Sim(e)) => Err(RunError::Sim(e).into()),
    }
}

/// The scores of one run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Score {
    /// Crossed the goal line.
    pub success: bool,
    /// Stopped jammed.
    pub jammed: bool,
    /// When it stopped (s): at the goal line, a jam or the time limit.
    pub end_secs: f64,
    /// When it crossed the goal line (s; NaN when it did not).
    pub time_to_goal_secs: f64,
    /// Forward advance of the centre of mass from its start (body lengths).
    pub distance_bl: f64,
    /// Body lengths per cycle of the base gait after the ramp-in.
    pub speed_bl_per_cycle: f64,
    /// Direction of motion over the last [`EXIT_WINDOW_SECS`] against that over the first
    /// after the ramp-in (degrees, −180 … 180; NaN for runs too short to have both).
    pub heading_change_deg: f64,
    /// Direction of the motion over the last [`EXIT_WINDOW_SECS`] (degrees from +x).
    pub exit_heading_deg: f64,
    /// Relative error of the estimated total obstacle force (Σ|est − true| / Σ true; NaN
    /// without estimates or without contact).
    pub estimate_error: f64,
    /// Share of the recorded instants (every 50 steps from t = 0) with a contact
    /// between two links.
    pub self_contact_share: f64,
    /// Largest total link–link contact force on one link (N).
    pub max_self_contact_n: f64,
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

/// Scores a trace (ramp-in `ramp_secs`, body length `body_m`; speeds per cycle of the base
/// gait).
pub fn score(trace: &Trace, ramp_secs: f64, body_m: f64) -> Score {
    let n = trace.time_secs.len();
    if n < 2 {
        return Score {
            time_to_goal_secs: f64::NAN,
            heading_change_deg: f64::NAN,
            estimate_error: f64::NAN,
            self_contact_share: f64::NAN,
            ..Score::default()
        };
    }
    let start = trace.time_secs.iter().position(|t| *t >= ramp_secs - 1e-9).unwrap_or(0).min(n - 1);
    let end_secs = trace.time_secs[n - 1];
    let span = end_secs - trace.time_secs[start];
    let advance = trace.com_m[n - 1][0] - trace.com_m[start][0];
    let speed = if span > 0.0 { advance / body_m / (FREQUENCY_HZ * span) } else { 0.0 };
    let direction = |from: usize, to: usize| {
        let d = [trace.com_m[to][0] - trace.com_m[from][0], trace.com_m[to][1] - trace.com_m[from][1]];
        d[1].atan2(d[0]).to_degrees()
    };
    let exit_from = trace.time_secs.iter().position(|t| *t >= end_secs - EXIT_WINDOW_SECS - 1e-9).unwrap_or(0);
    let exit = direction(exit_from, n - 1);
    let entry_to = trace.time_secs.iter().position(|t| *t >= trace.time_secs[start] + EXIT_WINDOW_SECS - 1e-9);
    let change = match entry_to {
        Some(e) if e <= exit_from => {
            let d = exit - direction(start, e);
            (d + 180.0).rem_euclid(360.0) - 180.0
        }
        _ => f64::NAN,
    };
    let truth: f64 = trace.true_n.iter().sum();
    let error: f64 = trace.estimated_n.iter().zip(&trace.true_n).map(|(e, t)| (e - t).abs()).sum();
    Score {
        success: trace.reached,
        jammed: trace.jammed,
        end_secs,
        time_to_goal_secs: if trace.reached { end_secs } else { f64::NAN },
        distance_bl: (trace.com_m[n - 1][0] - trace.com_m[0][0]) / body_m,
        speed_bl_per_cycle: speed,
        heading_change_deg: change,
        exit_heading_deg: exit,
        estimate_error: if truth > 0.0 { error / truth } else { f64::NAN },
        self_contact_share: trace.self_touching as f64 / n as f64,
        max_self_contact_n: trace.max_self_contact_n,
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

/// McNemar's exact test of paired successes: `b` pairs where only the first succeeded, `c`
/// where only the second did; the two-sided p of the binomial test of b against Bin(b + c, ½)
/// (1 without discordant pairs).
pub fn mcnemar_exact_p(b: usize, c: usize) -> f64 {
    let n = b + c;
    if n == 0 {
        return 1.0;
    }
    // Σ_{i ≤ min(b, c)} C(n, i) / 2ⁿ, in logs (n may be in the hundreds).
    let ln_choose = |n: usize, k: usize| -> f64 { (1..=k).map(|i| ((n - k + i) as f64).ln() - (i as f64).ln()).sum() };
    let tail: f64 = (0..=b.min(c)).map(|i| (ln_choose(n, i) - n as f64 * std::f64::consts::LN_2).exp()).sum();
    (2.0 * tail).min(1.0)
}

/// "m (lo – hi)".
fn with_interval(values: &[f64], statistic: fn(&[f64]) -> f64, scale: f64) -> String {
    let (lo, hi) = bootstrap_interval(values, statistic);
    format!("{} ({} – {})", sig(scale * statistic(values)), sig(scale * lo), sig(scale * hi))
}

/// Bare-floor speed (BL per base-gait cycle) of `config` over `duration_secs` (it stops at the
/// goal line like every run).
fn bare_speed(config: &Config, floor: Floor, duration_secs: f64) -> Result<f64, ExperimentError> {
    let mut c = config.clone();
    c.general.duration_secs = duration_secs;
    c.estimation.enabled = false;
    let trace = run_one(&c, floor, None)?.ok_or(ExperimentError::Interrupted { done: 0, planned: 1 })?;
    Ok(score(&trace, c.gait.ramp_secs, c.snake.n_links as f64 * c.snake.link_length_m).speed_bl_per_cycle)
}

/// The frequency (Hz) at which the stiff open loop of `bare` (a bare-floor config) goes
/// `target` BL per base-gait cycle: from the base gait's `base_speed`, three proportional
/// corrections (speed ∝ frequency for a quasi-static gait), within 0.05–2.5 Hz. `None` when
/// either speed is not forward (nothing to match). Returns the frequency and the speed reached.
pub fn match_frequency(
    bare: &Config,
    floor: Floor,
    base_speed: f64,
    target: f64,
    duration_secs: f64,
) -> Result<Option<(f64, f64)>, ExperimentError> {
    if !(base_speed > 0.0 && target > 0.0) {
        return Ok(None);
    }
    let (mut f, mut v) = (FREQUENCY_HZ, base_speed);
    for _ in 0..3 {
        if v <= 0.0 {
            return Ok(None);
        }
        f = (f * target / v).clamp(0.05, 2.5);
        let mut c = bare.clone();
        c.gait.sine_wave.frequency_hz = f;
        v = bare_speed(&c, floor, duration_secs)?;
    }
    Ok(Some((f, v)))
}

/// One passive gain on a bare floor: its speed and the stiff wave's matched frequency.
#[derive(Debug, Clone, Copy)]
pub struct PassiveMatch {
    /// The passive gain (N·m/rad).
    pub kp_nm_per_rad: f64,
    /// The passive gait's bare-floor speed (BL per base-gait cycle).
    pub speed_bl_per_cycle: f64,
    /// The stiff open loop's matched frequency (Hz) and its bare-floor speed, when matchable.
    pub matched: Option<(f64, f64)>,
}

/// What the bare floors say before any peg: per floor the base gait ([`bare_gait`], every step)
/// and each passive gain with its matched frequency.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// Per floor of the bench.
    pub base: Vec<BareGait>,
    /// Per floor, per passive gain.
    pub passive: Vec<Vec<PassiveMatch>>,
}

/// Measures the [`Calibration`] of `bench` on `pool` (bare floors, seed 0, no estimation).
pub fn calibrate(bench: &Bench, base: &Config, pool: &rayon::ThreadPool) -> Result<Calibration, ExperimentError> {
    use rayon::prelude::*;
    let secs = bench.duration_secs.min(CALIBRATION_SECS);
    let per_floor: Vec<Result<(BareGait, Vec<PassiveMatch>), ExperimentError>> = pool.install(|| {
        bench
            .floors
            .par_iter()
            .map(|&floor| {
                let mut bare = field_config(base, floor, Layout::Bare, 0);
                bare.estimation.enabled = false;
                let gait = bare_gait(&bare, secs)?;
                let passive: Vec<Result<PassiveMatch, ExperimentError>> = bench
                    .passive_kp_nm_per_rad
                    .par_iter()
                    .map(|&kp| {
                        let mut soft = bare.clone();
                        soft.control.position_kp_nm_per_rad = kp;
                        soft.control.position_kv_nm_s_per_rad = kp / 100.0;
                        let speed = bare_speed(&soft, floor, secs)?;
                        let matched = if bench.speed_matched {
                            match_frequency(&bare, floor, gait.speed_bl_per_cycle, speed, secs)?
                        } else {
                            None
                        };
                        Ok(PassiveMatch { kp_nm_per_rad: kp, speed_bl_per_cycle: speed, matched })
                    })
                    .collect();
                Ok((gait, passive.into_iter().collect::<Result<Vec<_>, _>>()?))
            })
            .collect()
    });
    let mut c = Calibration { base: Vec::new(), passive: Vec::new() };
    for r in per_floor {
        let (g, p) = r?;
        c.base.push(g);
        c.passive.push(p);
    }
    Ok(c)
}

/// The split of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Split {
    Tuning,
    HeldOut,
    /// The bare-floor twin of held-out runs (same floor, seed and condition; every family).
    Twin,
}

impl Split {
    fn name(self) -> &'static str {
        match self {
            Split::Tuning => "tuning",
            Split::HeldOut => "held_out",
            Split::Twin => "twin",
        }
    }
}

/// One run of the benchmark.
#[derive(Debug, Clone, Copy)]
struct Case {
    floor: usize,
    /// `None` for a twin.
    family: Option<usize>,
    seed: u64,
    split: Split,
    condition: usize,
}

/// One row of `oal_runs.csv`.
#[derive(Debug, Clone, PartialEq)]
struct Row {
    key: String,
    score: Score,
}

const RUNS_HEADER: &str = "floor,family,layout,seed,split,condition,success,jammed,end_s,time_to_goal_s,distance_bl,speed_bl_per_cycle,heading_change_deg,exit_heading_deg,estimate_error,self_contact_share,max_self_contact_n";

/// The plan of a bench: conditions, tuning cases, and (given the tuning rows) the held-out ones.
struct Plan<'a> {
    bench: &'a Bench,
    conditions: Vec<Condition>,
    calibration: Calibration,
}

impl Plan<'_> {
    /// The key columns of a case's row (floor … condition).
    fn key(&self, case: &Case) -> String {
        let (family, layout) = match case.family {
            Some(fa) => {
                let f = self.bench.families[fa];
                (f.name(), Layout::of(f, case.seed).name())
            }
            None => ("bare", Layout::Bare.name()),
        };
        format!(
            "{},{family},{layout},{},{},{}",
            self.bench.floors[case.floor].name(),
            case.seed,
            case.split.name(),
            self.conditions[case.condition].name
        )
    }

    fn in_group_of_many(&self, k: usize) -> bool {
        let g = &self.conditions[k].group;
        self.conditions.iter().filter(|c| &c.group == g).count() > 1
    }

    /// Every condition with alternatives on every tuning field.
    fn tuning_cases(&self) -> Vec<Case> {
        let mut cases = Vec::new();
        for floor in 0..self.bench.floors.len() {
            for family in 0..self.bench.families.len() {
                for seed in 0..self.bench.tuning_fields {
                    for condition in 0..self.conditions.len() {
                        if self.in_group_of_many(condition)
                            && !matches!(self.conditions[condition].kind, Kind::Matched(_))
                        {
                            cases.push(Case { floor, family: Some(family), seed, split: Split::Tuning, condition });
                        }
                    }
                }
            }
        }
        cases
    }

    /// Per floor, the conditions of the held-out fields: one member of each group (the tuning
    /// fields' choice: best success rate, then median distance, then the first), the matched
    /// open loop of the chosen passive gain when it could be matched.
    fn held_out_conditions(&self, tuning: &[(Case, Score)]) -> Vec<Vec<usize>> {
        (0..self.bench.floors.len())
            .map(|floor| {
                let key = |k: usize| {
                    let (mut s, mut d) = (Vec::new(), Vec::new());
                    for (c, sc) in tuning {
                        if c.floor == floor && c.condition == k {
                            s.push(if sc.success { 1.0 } else { 0.0 });
                            d.push(sc.distance_bl);
                        }
                    }
                    (mean(&s), median(&d))
                };
                let mut chosen: Vec<usize> = Vec::new();
                let mut groups: Vec<&str> = Vec::new();
                for c in &self.conditions {
                    if !groups.contains(&c.group.as_str()) && !matches!(c.kind, Kind::Matched(_)) {
                        groups.push(&c.group);
                    }
                }
                for g in groups {
                    let members: Vec<usize> =
                        (0..self.conditions.len()).filter(|&k| self.conditions[k].group == g).collect();
                    let best = members.iter().copied().fold(None, |best: Option<usize>, k| match best {
                        None => Some(k),
                        Some(b) => {
                            let (kb, kk) = (key(b), key(k));
                            let better = kk.0.total_cmp(&kb.0).then(kk.1.total_cmp(&kb.1)).is_gt();
                            Some(if better { k } else { b })
                        }
                    });
                    if let Some(b) = best {
                        chosen.push(b);
                    }
                }
                // The matched open loop of the chosen passive gain.
                let passive_kp = chosen.iter().find_map(|&k| match self.conditions[k].kind {
                    Kind::Passive(kp) => Some(kp),
                    _ => None,
                });
                for (k, c) in self.conditions.iter().enumerate() {
                    if let Kind::Matched(kp) = c.kind
                        && Some(kp) == passive_kp
                        && self.matched_hz(floor, kp).is_some()
                    {
                        chosen.push(k);
                    }
                }
                chosen.sort_unstable();
                chosen
            })
            .collect()
    }

    /// The matched frequency of passive gain `kp` on floor `floor`.
    fn matched_hz(&self, floor: usize, kp: f64) -> Option<f64> {
        self.calibration.passive[floor].iter().find(|p| p.kp_nm_per_rad == kp).and_then(|p| p.matched.map(|m| m.0))
    }

    /// The held-out cases, seed by seed (then floor, family, condition), each seed's twins after
    /// its fields.
    fn held_out_cases(&self, held: &[Vec<usize>]) -> Vec<Case> {
        let mut cases = Vec::new();
        for seed in self.bench.held_out_seeds() {
            for (floor, ks) in held.iter().enumerate() {
                for family in 0..self.bench.families.len() {
                    for &condition in ks {
                        cases.push(Case { floor, family: Some(family), seed, split: Split::HeldOut, condition });
                    }
                }
                if self.bench.twins {
                    for &condition in ks {
                        cases.push(Case { floor, family: None, seed, split: Split::Twin, condition });
                    }
                }
            }
        }
        cases
    }

    /// The config and controller of a case.
    fn config(&self, base: &Config, case: &Case) -> (Config, Option<Box<dyn Controller>>, Floor) {
        let floor = self.bench.floors[case.floor];
        let layout = match case.family {
            Some(fa) => Layout::of(self.bench.families[fa], case.seed),
            None => Layout::Bare,
        };
        let field = field_config(base, floor, layout, case.seed);
        let condition = &self.conditions[case.condition];
        let matched = match condition.kind {
            Kind::Matched(kp) => self.matched_hz(case.floor, kp),
            _ => None,
        };
        let config = condition_config(&field, condition, self.bench, matched);
        let n_joints = config.snake.n_links.saturating_sub(1);
        let controller: Option<Box<dyn Controller>> = match &condition.kind {
            Kind::Plugged(p) => Some((p.make)(&config, n_joints)),
            Kind::Compliance(g) => Some(Box::new(crate::control::BilateralCompliance::new(&config, n_joints, *g))),
            _ => None,
        };
        (config, controller, floor)
    }
}

fn format_row(key: &str, s: &Score) -> String {
    format!(
        "{key},{},{},{},{},{},{},{},{},{},{},{}\n",
        s.success,
        s.jammed,
        s.end_secs,
        s.time_to_goal_secs,
        s.distance_bl,
        s.speed_bl_per_cycle,
        s.heading_change_deg,
        s.exit_heading_deg,
        s.estimate_error,
        s.self_contact_share,
        s.max_self_contact_n
    )
}

/// Reads a runs table (`oal_runs.csv` or a shard's) into rows; errors name the file, the line
/// and what is wrong.
fn read_rows(path: &Path) -> Result<Vec<Row>, ExperimentError> {
    let text = std::fs::read_to_string(path).map_err(|source| ExperimentError::Io {
        what: "read",
        path: path.to_path_buf(),
        source,
    })?;
    let bad = |line: usize, what: String| {
        ExperimentError::Option(format!("{}, line {line}: {what} (not an oal-bench runs table)", path.display()))
    };
    let mut lines = text.lines();
    if lines.next() != Some(RUNS_HEADER) {
        return Err(bad(1, format!("the header is not `{RUNS_HEADER}`")));
    }
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != 17 {
            return Err(bad(i + 2, format!("{} cells, 17 expected", cells.len())));
        }
        let flag = |j: usize| match cells[j] {
            "true" => Ok(true),
            "false" => Ok(false),
            v => Err(bad(i + 2, format!("`{v}` in column {}: true or false expected", j + 1))),
        };
        let num = |j: usize| {
            cells[j].parse::<f64>().map_err(|_| bad(i + 2, format!("`{}` in column {}: not a number", cells[j], j + 1)))
        };
        let score = Score {
            success: flag(6)?,
            jammed: flag(7)?,
            end_secs: num(8)?,
            time_to_goal_secs: num(9)?,
            distance_bl: num(10)?,
            speed_bl_per_cycle: num(11)?,
            heading_change_deg: num(12)?,
            exit_heading_deg: num(13)?,
            estimate_error: num(14)?,
            self_contact_share: num(15)?,
            max_self_contact_n: num(16)?,
        };
        rows.push(Row { key: cells[..6].join(","), score });
    }
    Ok(rows)
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
    /// The report section (empty for a shard: its merge writes the report).
    pub section: Section,
    /// Runs done and planned (of this shard).
    pub runs_done: usize,
    pub runs_planned: usize,
    /// Held-out fields per family in the figures (fewer than planned after an interrupt).
    pub held_out_done: u64,
}

/// The shard file name of shard `(i, n)`.
fn shard_file(i: usize, n: usize) -> String {
    format!("oal_runs-shard-{i}-of-{n}.csv")
}

/// Runs the cases on `pool` in their order (each worker taking the next one: an interrupt
/// leaves a finished prefix); `None` for a run an interrupt stopped.
fn run_cases(
    plan: &Plan<'_>,
    base: &Config,
    pool: &rayon::ThreadPool,
    cases: &[Case],
    progress: Option<(&str, usize)>,
    runs_before: usize,
    cost: &std::sync::Mutex<Vec<(usize, f64, f64)>>,
) -> Vec<Result<Option<Trace>, ExperimentError>> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let slots: Vec<std::sync::Mutex<Option<RunResult>>> = cases.iter().map(|_| std::sync::Mutex::new(None)).collect();
    pool.scope(|scope| {
        for _ in 0..pool.current_num_threads() {
            scope.spawn(|_| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    let Some(case) = cases.get(i) else { break };
                    let result = if crate::interrupt::requested() {
                        Ok(None)
                    } else {
                        let (config, controller, floor) = plan.config(base, case);
                        let cpu_started = crate::cpu_time::thread_cpu_ns();
                        let r = run_one(&config, floor, controller);
                        let cpu_secs = crate::cpu_time::thread_cpu_ns().saturating_sub(cpu_started) as f64 * 1e-9;
                        if let Ok(Some(t)) = &r
                            && let Ok(mut c) = cost.lock()
                        {
                            let e = &mut c[case.condition];
                            *e = (e.0 + 1, e.1 + t.time_secs.last().copied().unwrap_or(0.0), e.2 + cpu_secs);
                        }
                        r
                    };
                    let n = done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
                    if let Some(c) = &plan.bench.on_progress {
                        c.report((runs_before + n) as u64, (runs_before + cases.len()) as u64);
                    }
                    if let Some((what, _)) = progress
                        && (n.is_multiple_of(50) || n == cases.len())
                    {
                        eprintln!("experiment oal-bench: {what}: {n} of {} runs done", cases.len());
                    }
                    if let Ok(mut slot) = slots[i].lock() {
                        *slot = Some(result);
                    }
                }
            });
        }
    });
    slots.into_iter().map(|s| s.into_inner().ok().flatten().unwrap_or(Ok(None))).collect()
}

/// Runs the benchmark `bench` on top of `base` on `pool`, writing its tables and plots into
/// `folder` (a shard writes only its runs table, `oal_runs-shard-i-of-n.csv`). Stops between
/// runs (and within one, at the next record) when an interrupt is requested
/// ([`crate::interrupt`]): during the tuning fields with [`ExperimentError::Interrupted`];
/// during the held-out fields with the tables and the section of the held-out seeds whose every
/// run finished (a prefix of the seeds: [`BenchOutcome::held_out_done`]), or `Interrupted` when
/// there is none.
pub fn run_bench(
    bench: &Bench,
    base: &Config,
    pool: &rayon::ThreadPool,
    folder: &Path,
    progress: bool,
) -> Result<BenchOutcome, ExperimentError> {
    bench.check()?;
    let calibration = calibrate(bench, base, pool)?;
    let plan = Plan { bench, conditions: bench.conditions(), calibration };
    let cost = std::sync::Mutex::new(vec![(0usize, 0.0f64, 0.0f64); plan.conditions.len()]);
    let tuning = plan.tuning_cases();
    let tuning_results = run_cases(&plan, base, pool, &tuning, progress.then_some(("tuning", 0)), 0, &cost);
    let mut tuning_traces = Vec::with_capacity(tuning.len());
    for r in tuning_results {
        match r? {
            Some(t) => tuning_traces.push(t),
            None => return Err(ExperimentError::Interrupted { done: tuning_traces.len(), planned: tuning.len() }),
        }
    }
    let (ramp, body_m) = (base_ramp_secs(base), body_length_m(base));
    let tuning_scored: Vec<(Case, Score)> =
        tuning.iter().copied().zip(tuning_traces.iter().map(|t| score(t, ramp, body_m))).collect();
    let held = plan.held_out_conditions(&tuning_scored);
    let all_held = plan.held_out_cases(&held);
    let mine: Vec<Case> = match bench.shard {
        Some((i, n)) => all_held.iter().enumerate().filter(|(k, _)| k % n == i).map(|(_, c)| *c).collect(),
        None => all_held.clone(),
    };
    let results =
        run_cases(&plan, base, pool, &mine, progress.then_some(("held-out fields and twins", 0)), tuning.len(), &cost);
    if progress && let Ok(c) = cost.lock() {
        for (k, (runs, sim_secs, cpu_secs)) in c.iter().enumerate() {
            if *runs > 0 {
                eprintln!(
                    "experiment oal-bench: {}: {runs} runs, {:.1} simulated s per run, {:.2} CPU s per run ({:.0} µs per step)",
                    plan.conditions[k].name,
                    sim_secs / *runs as f64,
                    cpu_secs / *runs as f64,
                    1e6 * cpu_secs / (sim_secs / base.general.timestep_secs).max(1.0),
                );
            }
        }
    }
    let mut traces = Vec::with_capacity(mine.len());
    for r in results {
        traces.push(r?);
    }
    let runs_done = tuning.len() + traces.iter().filter(|t| t.is_some()).count();
    let runs_planned = tuning.len() + mine.len();
    let mut runs = String::from(RUNS_HEADER);
    runs.push('\n');
    for (case, s) in &tuning_scored {
        runs.push_str(&format_row(&plan.key(case), s));
    }
    for (case, t) in mine.iter().zip(&traces) {
        if let Some(t) = t {
            runs.push_str(&format_row(&plan.key(case), &score(t, ramp, body_m)));
        }
    }
    if let Some((i, n)) = bench.shard {
        let path = folder.join(shard_file(i, n));
        std::fs::write(&path, runs).map_err(io(&path))?;
        if runs_done < runs_planned {
            return Err(ExperimentError::Interrupted { done: runs_done, planned: runs_planned });
        }
        let section = Section {
            heading: format!("Obstacle-aided locomotion benchmark, shard {i} of {n}"),
            text: format!(
                "{runs_done} runs in {}; join the shards with the same command and `--merge {}`.",
                shard_file(i, n),
                folder.display()
            ),
            tables: Vec::new(),
            checks: Vec::new(),
        };
        return Ok(BenchOutcome { section, runs_done, runs_planned, held_out_done: bench.held_out_fields });
    }
    // Interrupted: the held-out seeds whose every run (twins too) finished, a prefix.
    let mut held_out_done = bench.held_out_fields;
    if runs_done < runs_planned {
        let complete = |seed: u64| mine.iter().zip(&traces).filter(|(c, _)| c.seed == seed).all(|(_, t)| t.is_some());
        held_out_done = bench.held_out_seeds().into_iter().take_while(|&s| complete(s)).count() as u64;
        // The unfinished runs stay readable, marked incomplete.
        let path = folder.join("oal_runs-incomplete.csv");
        std::fs::write(&path, &runs).map_err(io(&path))?;
        if held_out_done == 0 {
            return Err(ExperimentError::Interrupted { done: runs_done, planned: runs_planned });
        }
        crate::interrupt::clear();
    }
    let last_seed = bench.first_held_out_seed + held_out_done;
    let (cases, kept): (Vec<Case>, Vec<Trace>) =
        mine.iter().zip(traces).filter(|(c, _)| c.seed < last_seed).map(|(c, t)| (*c, t.unwrap_or_default())).unzip();
    let rows: Vec<(Case, Score)> = cases.iter().copied().zip(kept.iter().map(|t| score(t, ramp, body_m))).collect();
    let mut section = report(&plan, base, folder, &tuning_scored, &rows, Some(&kept), held_out_done)?;
    if held_out_done < bench.held_out_fields {
        section.text.push_str(&format!(
            " **Stopped by an interrupt** after {held_out_done} of {} held-out fields per family: the figures \
             cover the held-out fields whose every run finished (every finished run: oal_runs-incomplete.csv).",
            bench.held_out_fields
        ));
    }
    Ok(BenchOutcome { section, runs_done, runs_planned, held_out_done })
}

/// Joins the shard runs tables (`oal_runs-shard-*-of-n.csv`) of `folder`, written by `bench`
/// with `shard = (i, n)` for every i, and writes the tables of the unsharded run (byte for byte
/// the same) and the report section. Errors name a missing shard, a missing or repeated run, or
/// tuning rows that differ between shards (not the same benchmark).
pub fn merge_shards(
    bench: &Bench,
    base: &Config,
    pool: &rayon::ThreadPool,
    folder: &Path,
) -> Result<Section, ExperimentError> {
    let mut unsharded = bench.clone();
    unsharded.shard = None;
    let bench = &unsharded;
    bench.check()?;
    let entries = std::fs::read_dir(folder).map_err(|source| ExperimentError::Io {
        what: "read",
        path: folder.to_path_buf(),
        source,
    })?;
    let mut files: Vec<(usize, usize, std::path::PathBuf)> = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if let Some(rest) = name.strip_prefix("oal_runs-shard-").and_then(|r| r.strip_suffix(".csv"))
            && let Some((i, n)) = rest.split_once("-of-")
            && let (Ok(i), Ok(n)) = (i.parse::<usize>(), n.parse::<usize>())
        {
            files.push((i, n, e.path()));
        }
    }
    files.sort();
    let Some(&(_, n, _)) = files.first() else {
        return Err(ExperimentError::Option(format!(
            "{}: no oal_runs-shard-*-of-*.csv files to merge (run the shards with --shard i/n --folder {0} first)",
            folder.display()
        )));
    };
    if files.iter().any(|f| f.1 != n) || files.len() != n || files.iter().enumerate().any(|(k, f)| f.0 != k) {
        let have: Vec<String> = files.iter().map(|f| format!("{}/{}", f.0, f.1)).collect();
        return Err(ExperimentError::Option(format!(
            "{}: shards {} found; a merge needs every shard 0/n … (n−1)/n of one n",
            folder.display(),
            have.join(", ")
        )));
    }
    let mut by_key: std::collections::HashMap<String, Score> = std::collections::HashMap::new();
    for (_, _, path) in &files {
        for row in read_rows(path)? {
            match by_key.get(&row.key) {
                Some(s) if !(s == &row.score || format_row("", s) == format_row("", &row.score)) => {
                    return Err(ExperimentError::Option(format!(
                        "{}: run `{}` differs from another shard's: not the same benchmark",
                        path.display(),
                        row.key
                    )));
                }
                _ => {
                    by_key.insert(row.key, row.score);
                }
            }
        }
    }
    let calibration = calibrate(bench, base, pool)?;
    let plan = Plan { bench, conditions: bench.conditions(), calibration };
    let take = |cases: &[Case]| -> Result<Vec<(Case, Score)>, ExperimentError> {
        cases
            .iter()
            .map(|c| {
                let key = plan.key(c);
                by_key.get(&key).map(|s| (*c, *s)).ok_or_else(|| {
                    ExperimentError::Option(format!(
                        "{}: no shard holds run `{key}` (a shard unfinished, or the shards ran other options)",
                        folder.display()
                    ))
                })
            })
            .collect()
    };
    let tuning = take(&plan.tuning_cases())?;
    let held = plan.held_out_conditions(&tuning);
    let rows = take(&plan.held_out_cases(&held))?;
    if by_key.len() != tuning.len() + rows.len() {
        return Err(ExperimentError::Option(format!(
            "{}: the shards hold {} runs, the benchmark plans {}: they ran other options",
            folder.display(),
            by_key.len(),
            tuning.len() + rows.len()
        )));
    }
    report(&plan, base, folder, &tuning, &rows, None, bench.held_out_fields)
}

/// The tables, plots and report section of a finished benchmark (`traces`: the held-out runs'
/// traces in `rows` order, for the path and estimate plots; `None` after a merge).
fn report(
    plan: &Plan<'_>,
    base: &Config,
    folder: &Path,
    tuning: &[(Case, Score)],
    rows: &[(Case, Score)],
    traces: Option<&[Trace]>,
    held_out_done: u64,
) -> Result<Section, ExperimentError> {
    let bench = plan.bench;
    let conditions = &plan.conditions;
    let held = plan.held_out_conditions(tuning);
    let body_m = body_length_m(base);

    // Per-run table.
    let runs_path = folder.join("oal_runs.csv");
    let mut csv = String::from(RUNS_HEADER);
    csv.push('\n');
    for (case, s) in tuning.iter().chain(rows) {
        csv.push_str(&format_row(&plan.key(case), s));
    }
    std::fs::write(&runs_path, csv).map_err(io(&runs_path))?;

    // Bare-floor calibration table.
    let bare_path = folder.join("oal_bare.csv");
    let mut bare_csv = String::from(
        "floor,gait,kp_nm_per_rad,frequency_hz,speed_bl_per_cycle,self_contact_share,max_self_contact_n,amplitude_reached_deg\n",
    );
    let mut bare_rows = Vec::new();
    for (fl, floor) in bench.floors.iter().enumerate() {
        let g = &plan.calibration.base[fl];
        bare_csv.push_str(&format!(
            "{},base,{SERVO_KP_NM_PER_RAD},{FREQUENCY_HZ},{},{},{},{}\n",
            floor.name(),
            g.speed_bl_per_cycle,
            g.self_contact_share,
            g.max_self_contact_n,
            g.amplitude_reached_deg
        ));
        bare_rows.push(vec![
            floor.name().to_string(),
            format!("base gait (kp {SERVO_KP_NM_PER_RAD})"),
            sig(FREQUENCY_HZ),
            sig(g.speed_bl_per_cycle),
            format!("{} ({} N at most)", sig(100.0 * g.self_contact_share), sig(g.max_self_contact_n)),
            sig(g.amplitude_reached_deg),
        ]);
        for p in &plan.calibration.passive[fl] {
            bare_csv.push_str(&format!(
                "{},passive,{},{FREQUENCY_HZ},{},,,\n",
                floor.name(),
                p.kp_nm_per_rad,
                p.speed_bl_per_cycle
            ));
            bare_rows.push(vec![
                floor.name().to_string(),
                format!("`passive_kp{}`", p.kp_nm_per_rad),
                sig(FREQUENCY_HZ),
                sig(p.speed_bl_per_cycle),
                String::new(),
                String::new(),
            ]);
            if let Some((f, v)) = p.matched {
                bare_csv.push_str(&format!("{},matched,{},{f},{v},,,\n", floor.name(), p.kp_nm_per_rad));
                bare_rows.push(vec![
                    floor.name().to_string(),
                    format!("`matched_kp{}` (stiff)", p.kp_nm_per_rad),
                    sig(f),
                    sig(v),
                    String::new(),
                    String::new(),
                ]);
            }
        }
    }
    std::fs::write(&bare_path, bare_csv).map_err(io(&bare_path))?;

    // Values of one condition on one floor × family (held out; `None`: the twins), in seed
    // order (paired).
    let values = |floor: usize, family: Option<usize>, condition: usize, f: fn(&Score) -> f64| -> Vec<f64> {
        rows.iter()
            .filter(|(c, _)| c.floor == floor && c.family == family && c.condition == condition)
            .map(|(_, s)| f(s))
            .collect()
    };
    let success = |s: &Score| if s.success { 1.0 } else { 0.0 };
    let jammed = |s: &Score| if s.jammed { 1.0 } else { 0.0 };
    let distance = |s: &Score| s.distance_bl;
    // A condition's peg effect on distance, field by field: its distance minus its twin's.
    let peg_effect = |floor: usize, family: usize, condition: usize| -> Vec<f64> {
        if !bench.twins {
            return Vec::new();
        }
        let twin: std::collections::HashMap<u64, f64> = rows
            .iter()
            .filter(|(c, _)| c.floor == floor && c.family.is_none() && c.condition == condition)
            .map(|(c, s)| (c.seed, s.distance_bl))
            .collect();
        rows.iter()
            .filter(|(c, _)| c.floor == floor && c.family == Some(family) && c.condition == condition)
            .map(|(c, s)| s.distance_bl - twin.get(&c.seed).copied().unwrap_or(f64::NAN))
            .collect()
    };
    let passive_of =
        |floor: usize| held[floor].iter().copied().find(|&k| matches!(conditions[k].kind, Kind::Passive(_)));
    let matched_of =
        |floor: usize| held[floor].iter().copied().find(|&k| matches!(conditions[k].kind, Kind::Matched(_)));
    let compliance_of =
        |floor: usize| held[floor].iter().copied().find(|&k| matches!(conditions[k].kind, Kind::Compliance(_)));
    let heading_of =
        |floor: usize| held[floor].iter().copied().find(|&k| matches!(conditions[k].kind, Kind::HeadingHold));
    let quartiles = |mut v: Vec<f64>| -> [f64; 3] {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        [0.25, 0.5, 0.75].map(|p| {
            if v.is_empty() { f64::NAN } else { v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)] }
        })
    };
    let opt = |x: f64| if x.is_finite() { sig(x) } else { String::new() };

    // Summary per floor × family × condition (held-out fields).
    let mut summary_rows = Vec::new();
    let mut summary_csv = String::from(
        "floor,family,condition,fields,success_rate,success_lo,success_hi,jam_rate,median_distance_bl,distance_lo,distance_hi,median_time_to_goal_s,median_speed_bl_per_cycle,heading_change_q25_deg,heading_change_median_deg,heading_change_q75_deg,twin_median_distance_bl,peg_effect_mean_bl,peg_effect_lo,peg_effect_hi,estimate_error_median,self_contact_runs,self_contact_share_mean,max_self_contact_n\n",
    );
    let mut heading_csv = String::from("floor,family,condition,bin_lo_deg,bin_hi_deg,runs\n");
    for (fl, floor) in bench.floors.iter().enumerate() {
        for (fa, family) in bench.families.iter().enumerate() {
            for &k in &held[fl] {
                let condition = &conditions[k];
                let s = values(fl, Some(fa), k, success);
                let d = values(fl, Some(fa), k, distance);
                let heading = values(fl, Some(fa), k, |s| s.heading_change_deg);
                for b in 0..24 {
                    let lo = -180.0 + 15.0 * b as f64;
                    let n =
                        heading.iter().filter(|h| **h >= lo && (**h < lo + 15.0 || (b == 23 && **h <= 180.0))).count();
                    heading_csv.push_str(&format!(
                        "{},{},{},{lo},{},{n}\n",
                        floor.name(),
                        family.name(),
                        condition.name,
                        lo + 15.0
                    ));
                }
                let hq = quartiles(heading);
                let twin = median(&values(fl, None, k, distance));
                let effect = peg_effect(fl, fa, k);
                let (elo, ehi) = bootstrap_interval(&effect, mean);
                let err = median(&values(fl, Some(fa), k, |s| s.estimate_error));
                let self_runs = mean(&values(fl, Some(fa), k, |s| if s.self_contact_share > 0.0 { 1.0 } else { 0.0 }));
                let self_share = mean(&values(fl, Some(fa), k, |s| s.self_contact_share));
                let self_n = values(fl, Some(fa), k, |s| s.max_self_contact_n).into_iter().fold(0.0, f64::max);
                let (slo, shi) = bootstrap_interval(&s, mean);
                let (dlo, dhi) = bootstrap_interval(&d, median);
                let goal_time = median(&values(fl, Some(fa), k, |s| s.time_to_goal_secs));
                let speed = median(&values(fl, Some(fa), k, |s| s.speed_bl_per_cycle));
                let jam = mean(&values(fl, Some(fa), k, jammed));
                summary_csv.push_str(&format!(
                    "{},{},{},{},{},{slo},{shi},{jam},{},{dlo},{dhi},{goal_time},{speed},{},{},{},{twin},{},{elo},{ehi},{err},{self_runs},{self_share},{self_n}\n",
                    floor.name(),
                    family.name(),
                    condition.name,
                    s.len(),
                    mean(&s),
                    median(&d),
                    hq[0],
                    hq[1],
                    hq[2],
                    mean(&effect),
                ));
                let tag = match condition.kind {
                    Kind::Passive(_) => " (passive baseline)",
                    Kind::Compliance(_) => " (compliance baseline)",
                    Kind::Matched(_) => " (speed-matched open loop)",
                    _ => "",
                };
                summary_rows.push(vec![
                    floor.name().to_string(),
                    family.name().to_string(),
                    format!("`{}`{tag}", condition.name),
                    s.len().to_string(),
                    with_interval(&s, mean, 100.0),
                    sig(100.0 * jam),
                    with_interval(&d, median, 1.0),
                    opt(goal_time),
                    sig(speed),
                    format!("{} / {} / {}", opt(hq[0]), opt(hq[1]), opt(hq[2])),
                    opt(twin),
                    if effect.is_empty() { String::new() } else { with_interval(&effect, mean, 1.0) },
                    opt(err),
                    format!("{} / {} / {}", sig(100.0 * self_runs), sig(100.0 * self_share), sig(self_n)),
                ]);
            }
        }
    }
    let summary_path = folder.join("oal_summary.csv");
    std::fs::write(&summary_path, summary_csv).map_err(io(&summary_path))?;
    let heading_path = folder.join("oal_heading.csv");
    std::fs::write(&heading_path, heading_csv).map_err(io(&heading_path))?;

    // Paired differences of every condition but open loop against its baselines: open loop,
    // the passive baseline and the speed-matched open loop; a law on estimated contacts also
    // against the same law on true contacts.
    let truth_of = |floor: usize, k: usize| -> Option<usize> {
        match conditions[k].kind {
            Kind::Law(kind, ContactSource::Estimated, _) => held[floor]
                .iter()
                .copied()
                .find(|&t| matches!(conditions[t].kind, Kind::Law(other, ContactSource::True, _) if other == kind)),
            _ => None,
        }
    };
    let mut paired_rows = Vec::new();
    let mut paired_csv = String::from(
        "floor,family,condition,against,success_difference,success_lo,success_hi,only_condition,only_against,mcnemar_p,distance_difference_bl,distance_lo,distance_hi,peg_effect_difference_bl,peg_effect_lo,peg_effect_hi\n",
    );
    // Per condition: (worst lower bound of the success difference, largest McNemar p) over the
    // floors, families and baselines (open loop, passive, matched).
    let mut target: Vec<(f64, f64)> = vec![(f64::INFINITY, 0.0); conditions.len()];
    for (fl, floor) in bench.floors.iter().enumerate() {
        for (fa, family) in bench.families.iter().enumerate() {
            for &k in &held[fl] {
                let mut against: Vec<usize> = Vec::new();
                match conditions[k].kind {
                    Kind::OpenLoop | Kind::Matched(_) => continue,
                    Kind::Passive(_) | Kind::Compliance(_) | Kind::HeadingHold => {
                        against.extend([Some(0), matched_of(fl)].into_iter().flatten())
                    }
                    _ => against.extend(
                        [Some(0), passive_of(fl), matched_of(fl), compliance_of(fl), heading_of(fl), truth_of(fl, k)]
                            .into_iter()
                            .flatten(),
                    ),
                }
                for other in against {
                    let a = values(fl, Some(fa), k, success);
                    let b = values(fl, Some(fa), other, success);
                    let d: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
                    let only_a = a.iter().zip(&b).filter(|(x, y)| **x > **y).count();
                    let only_b = a.iter().zip(&b).filter(|(x, y)| **x < **y).count();
                    let p = mcnemar_exact_p(only_a, only_b);
                    let (lo, hi) = bootstrap_interval(&d, mean);
                    let dd: Vec<f64> = values(fl, Some(fa), k, distance)
                        .iter()
                        .zip(&values(fl, Some(fa), other, distance))
                        .map(|(x, y)| x - y)
                        .collect();
                    let (dlo, dhi) = bootstrap_interval(&dd, mean);
                    let pe: Vec<f64> =
                        peg_effect(fl, fa, k).iter().zip(&peg_effect(fl, fa, other)).map(|(x, y)| x - y).collect();
                    let (plo, phi) = bootstrap_interval(&pe, mean);
                    paired_csv.push_str(&format!(
                        "{},{},{},{},{},{lo},{hi},{only_a},{only_b},{p},{},{dlo},{dhi},{},{plo},{phi}\n",
                        floor.name(),
                        family.name(),
                        conditions[k].name,
                        conditions[other].name,
                        mean(&d),
                        mean(&dd),
                        mean(&pe),
                    ));
                    if truth_of(fl, k) != Some(other) {
                        let t = &mut target[k];
                        *t = (t.0.min(lo), t.1.max(p));
                    }
                    paired_rows.push(vec![
                        floor.name().to_string(),
                        family.name().to_string(),
                        format!("`{}`", conditions[k].name),
                        format!("`{}`", conditions[other].name),
                        format!("{} ({} – {})", sig(100.0 * mean(&d)), sig(100.0 * lo), sig(100.0 * hi)),
                        format!("{} ({only_a} / {only_b})", sig(p)),
                        format!("{} ({} – {})", sig(mean(&dd)), sig(dlo), sig(dhi)),
                        if pe.is_empty() {
                            String::new()
                        } else {
                            format!("{} ({} – {})", sig(mean(&pe)), sig(plo), sig(phi))
                        },
                    ]);
                }
            }
        }
    }
    let paired_path = folder.join("oal_paired.csv");
    std::fs::write(&paired_path, paired_csv).map_err(io(&paired_path))?;

    // The checks: the base gait clears itself on every bare floor; the isotropic floor gives it
    // no propulsion of its own; the target (a contact law on estimated contacts beats open loop,
    // the passive baseline and the speed-matched open loop on success on every floor and family:
    // paired 90 % interval above 0, McNemar p < 0.05).
    let mut checks = Vec::new();
    for (fl, floor) in bench.floors.iter().enumerate() {
        let g = &plan.calibration.base[fl];
        checks.push(Check::at_most(
            &format!("{} floor without pegs: steps of the base gait with a link–link contact", floor.name()),
            100.0 * g.self_contact_share,
            0.0,
            "%",
        ));
        if *floor == Floor::Isotropic {
            checks.push(Check::at_most(
                "isotropic floor without pegs: the base gait's speed (≤ 0: every advance among pegs is peg-aided)",
                g.speed_bl_per_cycle,
                0.0,
                "BL/cycle",
            ));
        }
    }
    for (k, c) in conditions.iter().enumerate() {
        if !matches!(c.kind, Kind::Law(_, ContactSource::Estimated, _) | Kind::Plugged(_)) || target[k].0.is_infinite()
        {
            continue;
        }
        checks.push(Check::at_least(
            &format!(
                "`{}`: lower 90 % bound of the paired success gain over the baselines (open loop, passive, speed-matched, compliance when run), worst floor × family (above 0 to beat them)",
                c.name
            ),
            100.0 * target[k].0,
            0.01,
            "points",
        ));
        checks.push(Check::at_most(
            &format!("`{}`: McNemar's exact p of the same comparisons, the largest", c.name),
            target[k].1,
            0.05,
            "",
        ));
    }

    // Plots.
    let plots = folder.join("plots");
    std::fs::create_dir_all(&plots).map_err(io(&plots))?;
    for (fl, floor) in bench.floors.iter().enumerate() {
        for (fa, family) in bench.families.iter().enumerate() {
            let (mut s, mut slo, mut shi, mut v, mut vlo, mut vhi) = (vec![], vec![], vec![], vec![], vec![], vec![]);
            for &k in &held[fl] {
                let ss = values(fl, Some(fa), k, success);
                let (lo, hi) = bootstrap_interval(&ss, mean);
                s.push(100.0 * mean(&ss));
                slo.push(100.0 * lo);
                shi.push(100.0 * hi);
                let dd = values(fl, Some(fa), k, distance);
                let (lo, hi) = bootstrap_interval(&dd, median);
                v.push(median(&dd));
                vlo.push(lo);
                vhi.push(hi);
            }
            let names: Vec<String> = held[fl].iter().map(|&k| conditions[k].name.clone()).collect();
            let title = |what: &str| {
                format!("{} floor, {} fields (held out): {what} with 90 % interval", floor.name(), family.name())
            };
            crate::plot::plot_intervals(
                &plots,
                &format!("oal_success_{}_{}", floor.name(), family.name()),
                &title("success rate"),
                "success (%)",
                &names,
                &s,
                &slo,
                &shi,
            )
            .map_err(plot_error)?;
            crate::plot::plot_intervals(
                &plots,
                &format!("oal_distance_{}_{}", floor.name(), family.name()),
                &title("median distance"),
                "distance (body lengths)",
                &names,
                &v,
                &vlo,
                &vhi,
            )
            .map_err(plot_error)?;
            let Some(traces) = traces else { continue };
            for seed in bench.held_out_seeds().into_iter().take(bench.path_fields.min(held_out_done) as usize) {
                let layout = Layout::of(*family, seed);
                let field = field_config(base, *floor, layout, seed);
                let pegs: Vec<([f64; 2], f64)> = crate::model::generate(&field)
                    .map_err(|e| ExperimentError::Data(format!("field {} seed {seed}: {e}", layout.name())))?
                    .obstacles
                    .iter()
                    .map(|c| (c.center_m, c.radius_m))
                    .collect();
                let paths: Vec<(String, Vec<f64>, Vec<f64>)> = rows
                    .iter()
                    .zip(traces)
                    .filter(|((c, _), _)| c.floor == fl && c.family == Some(fa) && c.seed == seed)
                    .map(|((c, _), t)| {
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
            let first = bench.first_held_out_seed;
            for ((c, _), t) in rows.iter().zip(traces) {
                let condition = &conditions[c.condition];
                if c.floor != fl || c.family != Some(fa) || c.seed != first || t.estimated_n.is_empty() {
                    continue;
                }
                crate::plot::plot_time_series(
                    &plots,
                    &format!("oal_estimate_{}_{}_{}", condition.name, floor.name(), family.name()),
                    &format!(
                        "{}, {} floor, {} seed {first}: obstacle force on the body (Σ|f_xy|)",
                        condition.name,
                        floor.name(),
                        family.name()
                    ),
                    "force (N)",
                    &t.time_secs[..t.estimated_n.len()],
                    &[("estimated".to_string(), t.estimated_n.clone()), ("true".to_string(), t.true_n.clone())],
                )
                .map_err(plot_error)?;
            }
        }
    }

    let chosen_text: Vec<String> = bench
        .floors
        .iter()
        .zip(&held)
        .map(|(f, ks)| {
            let tuned: Vec<String> = ks
                .iter()
                .filter(|&&k| plan.in_group_of_many(k) && !matches!(conditions[k].kind, Kind::Matched(_)))
                .map(|&k| format!("`{}`", conditions[k].name))
                .collect();
            format!("{}: {}", f.name(), if tuned.is_empty() { "nothing to choose".into() } else { tuned.join(", ") })
        })
        .collect();
    let tuning_runs_per_field =
        tuning.len() as u64 / (bench.tuning_fields * (bench.floors.len() * bench.families.len()) as u64).max(1);
    let reference = field_config(base, Floor::Isotropic, Layout::Bare, 0);
    let h0 = bench.first_held_out_seed;
    let section = Section {
        heading: "Obstacle-aided locomotion benchmark".into(),
        text: format!(
            "10 links ({link} m), base gait A = {BASE_AMPLITUDE_DEG}°, δ = {BASE_PHASE_LAG_DEG}° (toward the tail, \
             λ = {lambda} m along the body), {FREQUENCY_HZ} Hz, position servos kp {SERVO_KP_NM_PER_RAD} N·m/rad, kv \
             {SERVO_KV_NM_S_PER_RAD} N·m·s/rad (the defaults), ±{TORQUE_LIMIT_NM} N·m{law_servos}, default sensor noise. \
             Floors: {floors}; goal line {goals} ahead of the starting centre of mass; time limit {dur} s; a run stops \
             at the goal line or when jammed (less than {JAM_PROGRESS_M} m of new forward progress in \
             {JAM_WINDOW_SECS} s after the {ramp}-s ramp-in). Layouts inside a channel (walls at y = ±{WALL_Y_M} m): \
             {families}; peg radius 0.05 m, none on the starting snake. Seeds: tuning 0..{nt}, held out {h0}..{h1} per \
             family (field `seed` has layout seed mod 6 (lattice: square and hexagonal at {lat} m) or mod 3 (random: \
             {densities} pegs/m²; row: posts at x = {ROW_X_M} m, {rows} m apart)); every figure below and every check \
             is on the held-out fields. Tuning budget: {nt} fields per family, {tuning_runs_per_field} runs per field \
             (passive gains {passive:?} N·m/rad; each law's gains × {scales:?}); chosen: {chosen}. Twins: {twins}. \
             Distance: forward advance of the centre of mass (body lengths); peg effect: distance minus the twin's. \
             Heading change: direction of the last {EXIT_WINDOW_SECS} s of motion against the first {EXIT_WINDOW_SECS} \
             s after the ramp-in (the scattering angle; histogram in oal_heading.csv). Intervals: 90 % percentile \
             bootstrap over the fields ({RESAMPLES} resamples, fixed seed); paired differences per field; McNemar's \
             exact two-sided p with the discordant fields (only the condition / only the baseline succeeded). Files: \
             oal_runs.csv, oal_summary.csv, oal_paired.csv, oal_heading.csv, oal_bare.csv, plots/.",
            link = reference.snake.link_length_m,
            lambda = sig(body_wavelength_m(&reference)),
            law_servos = match bench.law_servo_kp_nm_per_rad {
                Some(kp) => format!(" (the contact laws on soft servos: kp {kp} N·m/rad, kv {} N·m·s/rad)", kp / 100.0),
                None => String::new(),
            },
            floors = bench.floors.iter().map(|f| f.name()).collect::<Vec<_>>().join(", "),
            goals = bench
                .floors
                .iter()
                .map(|f| format!(
                    "{} body lengths ({} m) on the {} floor",
                    goal_body_lengths(*f),
                    sig(goal_body_lengths(*f) * body_m),
                    f.name()
                ))
                .collect::<Vec<_>>()
                .join(", "),
            dur = bench.duration_secs,
            ramp = base_ramp_secs(base),
            families = bench.families.iter().map(|f| f.name()).collect::<Vec<_>>().join(", "),
            nt = bench.tuning_fields,
            h1 = h0 + held_out_done,
            lat = LATTICE_SPACING_M.map(sig).join(", "),
            densities = RANDOM_PEGS_PER_M2.map(sig).join(", "),
            rows = ROW_SPACING_M.map(sig).join(", "),
            passive = bench.passive_kp_nm_per_rad,
            scales = bench.law_gain_scales,
            chosen = chosen_text.join("; "),
            twins = if bench.twins {
                "every held-out run again on the bare floor (same seed, same walls, no pegs)"
            } else {
                "off"
            },
        ),
        tables: vec![
            (
                [
                    "floor",
                    "gait",
                    "frequency (Hz)",
                    "bare-floor speed (BL/cycle)",
                    "steps with link–link contact (%)",
                    "amplitude reached (°)",
                ]
                .map(String::from)
                .to_vec(),
                bare_rows,
            ),
            (
                [
                    "floor",
                    "family",
                    "condition",
                    "fields",
                    "success (%; 90 % interval)",
                    "jammed (%)",
                    "median distance (BL; 90 % interval)",
                    "median time to goal (s)",
                    "median speed (BL/cycle)",
                    "heading change (°; q25 / median / q75)",
                    "twin: median distance (BL)",
                    "peg effect on distance (BL; mean, 90 % interval)",
                    "estimate error (median Σ‖est − true‖ / Σ true)",
                    "self-contact: runs touching (%) / mean share of the run (%) / largest force (N)",
                ]
                .map(String::from)
                .to_vec(),
                summary_rows,
            ),
            (
                [
                    "floor",
                    "family",
                    "condition",
                    "against",
                    "success difference (points; 90 % interval)",
                    "McNemar p (only condition / only against)",
                    "distance difference (BL; 90 % interval)",
                    "peg-effect difference (BL; 90 % interval)",
                ]
                .map(String::from)
                .to_vec(),
                paired_rows,
            ),
        ],
        checks,
    };
    Ok(section)
}

/// Runs `bench` into `folder` (`None`: a new folder `<out>/oal-bench-<UTC time>/`) and writes its
/// `report.md` there (`intro`: how it was started); returns the folder and the report.
pub fn run_into(
    bench: &Bench,
    base: &Config,
    pool: &rayon::ThreadPool,
    out: &Path,
    intro: &str,
    progress: bool,
) -> Result<(std::path::PathBuf, super::Report), ExperimentError> {
    // Before the folder exists: bad sizes leave nothing behind.
    bench.check()?;
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

/// The experiment: [`Bench::quick`] or [`Bench::full`], or the bench the command line gave
/// ([`super::ExperimentOptions::oal`]), run, sharded or merged.
pub fn run(ctx: &super::Context, base: &Config) -> Result<Section, ExperimentError> {
    let bench = ctx
        .oal
        .as_ref()
        .map(|o| o.bench.clone())
        .unwrap_or_else(|| if ctx.quick { Bench::quick() } else { Bench::full() });
    if ctx.oal.as_ref().is_some_and(|o| o.merge) {
        return merge_shards(&bench, base, &ctx.pool, &ctx.folder);
    }
    let outcome = run_bench(&bench, base, &ctx.pool, &ctx.folder, ctx.progress)?;
    if outcome.held_out_done < bench.held_out_fields {
        // The command's contract on a signal: exit 130 with an incomplete report (the tables of
        // the finished fields are in the folder).
        return Err(ExperimentError::Interrupted { done: outcome.runs_done, planned: outcome.runs_planned });
    }
    Ok(outcome.section)
}

/// The `oal-bench` options of `simserpent experiment`: the bench, and whether to merge shards.
#[derive(Clone)]
pub struct OalOptions {
    /// The benchmark to run (its shard, if any).
    pub bench: Bench,
    /// Join the shards in the experiment folder instead of running.
    pub merge: bool,
}

impl std::fmt::Debug for OalOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let b = &self.bench;
        f.debug_struct("OalOptions")
            .field("tuning_fields", &b.tuning_fields)
            .field("held_out_fields", &b.held_out_fields)
            .field("first_held_out_seed", &b.first_held_out_seed)
            .field("duration_secs", &b.duration_secs)
            .field("floors", &b.floors)
            .field("families", &b.families)
            .field("conditions", &b.conditions().iter().map(|c| c.name.clone()).collect::<Vec<_>>())
            .field("shard", &b.shard)
            .field("merge", &self.merge)
            .finish()
    }
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

    /// `heading_gain` adds the baseline `open_loop_heading` (a law with its contact terms off and
    /// the heading hold on) and gives every law the same heading hold; 0 leaves both out.
    #[test]
    fn the_heading_switch_adds_its_baseline_and_steers_every_law() {
        let names = |b: &Bench| b.conditions().iter().map(|c| c.name().to_string()).collect::<Vec<_>>();
        assert!(!names(&Bench::quick()).iter().any(|n| n == "open_loop_heading"));
        let bench = Bench { heading_gain: 0.4, ..Bench::quick() };
        assert!(bench.check().is_ok());
        let conditions = bench.conditions();
        let field = field_config(&Config::default(), Floor::Anisotropic, Layout::Bare, 1000);
        let heading = conditions.iter().find(|c| c.name() == "open_loop_heading").expect("the baseline");
        let c = condition_config(&field, heading, &bench, None);
        assert_eq!(c.control.controller, ControllerKind::FollowTheLeaderReflex);
        assert!(!c.follow_the_leader_reflex.feedback);
        assert_eq!(c.follow_the_leader_reflex.heading_gain, 0.4);
        c.validate().expect("a valid config");
        for law in conditions.iter().filter(|c| matches!(c.kind, Kind::Law(..))) {
            let c = condition_config(&field, law, &bench, None);
            assert_eq!(c.follow_the_leader_reflex.heading_gain, 0.4, "{}", law.name());
            assert_eq!(c.directional_admittance.heading_gain, 0.4, "{}", law.name());
            assert_eq!(c.jam_resolution.heading_gain, 0.4, "{}", law.name());
            assert_eq!(c.jam_resolution.heading_max_offset_deg, HEADING_MAX_OFFSET_DEG);
        }
        let off = condition_config(&field, &conditions[0], &bench, None);
        assert_eq!(off.follow_the_leader_reflex.heading_gain, 0.0, "the open loop does not steer");
        assert!(Bench { heading_gain: -1.0, ..Bench::quick() }.check().is_err());
        assert!(Bench { heading_gain: f64::NAN, ..Bench::quick() }.check().is_err());
    }

    #[test]
    fn jams_are_counted_per_window_without_progress() {
        // 0.01 m/s: 0.1 m per 10 s, no jam.
        let moving: Vec<(f64, f64)> = (0..=300).map(|k| (0.1 * k as f64, 0.001 * k as f64)).collect();
        assert_eq!(count_jams(&moving, 1.0), 0);
        // Standing still for 30 s after the 1-s ramp: windows [1, 11], [11, 21] → 2 whole
        // windows end inside the path (the next would end at 31 s > 30 s).
        let still: Vec<(f64, f64)> = (0..=300).map(|k| (0.1 * k as f64, 0.0)).collect();
        assert_eq!(count_jams(&still, 1.0), 2);
    }

    #[test]
    fn scores_of_a_straight_run() {
        // 0.1 m/s along +x for 20 s, base gait 0.5 Hz, body 2 m: 0.1 BL/cycle, 1 BL, heading
        // change 0, no jam.
        let t = trace(&(0..=200).map(|k| 0.01 * k as f64).collect::<Vec<_>>(), 0.1);
        let s = score(&t, 2.0, 2.0);
        assert!((s.speed_bl_per_cycle - 0.1).abs() < 1e-12, "{}", s.speed_bl_per_cycle);
        assert!((s.distance_bl - 1.0).abs() < 1e-12, "{}", s.distance_bl);
        assert!(s.exit_heading_deg.abs() < 1e-12);
        assert!(s.heading_change_deg.abs() < 1e-12);
        assert!(!s.success && !s.jammed && s.time_to_goal_secs.is_nan());
    }

    /// The self-contact share is over every recorded instant from t = 0, the largest force as
    /// recorded; a run too short to score has no share.
    #[test]
    fn self_contact_is_the_share_of_recorded_instants_touching() {
        let mut t = trace(&(0..=200).map(|k| 0.01 * k as f64).collect::<Vec<_>>(), 0.1);
        t.self_touching = 67;
        t.max_self_contact_n = 4.5;
        let s = score(&t, 2.0, 2.0);
        assert!((s.self_contact_share - 67.0 / 201.0).abs() < 1e-15, "{}", s.self_contact_share);
        assert_eq!(s.max_self_contact_n, 4.5);
        assert_eq!(score(&trace(&[0.0, 0.1], 0.1), 0.0, 2.0).self_contact_share, 0.0);
        assert!(score(&trace(&[0.0], 0.1), 0.0, 2.0).self_contact_share.is_nan());
    }

    #[test]
    fn a_turn_is_a_heading_change() {
        // Along +x for 10 s, then along +y for 10 s: +90°.
        let mut t = Trace::default();
        for k in 0..=200 {
            let s = 0.1 * k as f64;
            t.time_secs.push(s);
            t.com_m.push(if s <= 10.0 { [0.01 * k as f64, 0.0] } else { [1.0, 0.01 * (k - 100) as f64] });
        }
        let s = score(&t, 0.0, 2.0);
        assert!((s.heading_change_deg - 90.0).abs() < 1e-9, "{}", s.heading_change_deg);
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

    /// McNemar's exact p against values from the binomial distribution: 0 vs 6 discordant
    /// pairs 2·(½)⁶ = 0.03125; 1 vs 9: 2·11/1024 = 0.021484375; 13 vs 4 (17 pairs):
    /// 2·(1 + 17 + 136 + 680 + 2380)/131072 = 0.049041748046875.
    #[test]
    fn mcnemar_exact_p_matches_the_binomial_tail() {
        assert_eq!(mcnemar_exact_p(0, 0), 1.0);
        assert!((mcnemar_exact_p(0, 6) - 0.03125).abs() < 1e-12);
        assert!((mcnemar_exact_p(9, 1) - 0.021484375).abs() < 1e-12);
        assert!((mcnemar_exact_p(13, 4) - 0.049041748046875).abs() < 1e-12);
        assert_eq!(mcnemar_exact_p(5, 5), 1.0);
    }

    #[test]
    fn layouts_cycle_through_each_family() {
        assert_eq!(Layout::of(Family::Lattice, 0), Layout::Square(0.5));
        assert_eq!(Layout::of(Family::Lattice, 5), Layout::Hexagonal(0.7));
        assert_eq!(Layout::of(Family::Random, 4), Layout::Random(3.0));
        assert_eq!(Layout::of(Family::Row, 2), Layout::Row(0.5));
    }
}

//! Configuration: one TOML file (or the original tool's `config.json`) describes a whole run.
//!
//! Pipeline (see ARCHITECTURE.md): the user's file is parsed into a `toml::Table`, checked key by
//! key against the embedded default (`default.toml`, which is also what `simserpent init` writes),
//! merged onto it, overridden by `--set key.path=value`, deserialized into [`Config`] with key
//! paths in errors, and finally validated ([`Config::validate`]). Every error names the key path,
//! the value and what is allowed.
//!
//! Does: parse, merge, override, validate. Does not: touch files other than the config itself,
//! or MuJoCo.

pub mod files;
mod floor;
mod legacy;
mod load;
pub mod presets;
mod ros2;
pub mod surfaces;
mod text;
mod validate;

pub use floor::{AutoSecs, STICK_RELEASE_J, StickTimeConstant};

/// The most obstacles a terrain may have.
pub const MAX_OBSTACLES: usize = 100_000;
pub use legacy::{
    LEGACY_DEVIATIONS, LEGACY_RULES, LegacyConversion, LegacyDeviation, LegacyNote, LegacyRule, legacy_deviation_table,
    legacy_rule_table,
};
pub use load::{
    ConfigSource, convert_legacy_file, convert_legacy_text, load_config, load_config_str, load_config_with_notes,
    parse_override,
};
pub use ros2::{Ros2, Ros2Clock, Ros2Durability, Ros2Reliability};
pub use surfaces::{ExplicitFriction, FrictionSource, PRESETS, Preset, Surface, SurfaceFriction, SurfaceShape};

use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The embedded, fully commented default configuration.
pub const DEFAULT_CONFIG_TOML: &str = include_str!("default.toml");

/// A configuration problem: which key, what value, what is allowed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// A key that the configuration does not have.
    #[error("unknown key `{}`{}; allowed keys here: {allowed}", shorten(key), suggestion.as_ref().map(|s| format!(" (did you mean `{s}`?)")).unwrap_or_default())]
    UnknownKey {
        /// Full key path.
        key: String,
        /// Closest known key, if any is close.
        suggestion: Option<String>,
        /// The keys allowed in that table.
        allowed: String,
    },
    /// A value of the wrong type or out of range.
    #[error("`{}` = {}: {allowed}", shorten(key), shorten(value))]
    InvalidValue {
        /// Full key path.
        key: String,
        /// The offending value as written.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// The file could not be parsed at all.
    #[error("{}: {}", shorten(file), shorten_lines(message))]
    Syntax {
        /// The file (or `--set` argument).
        file: String,
        /// Parser message (with line and column when known).
        message: String,
    },
    /// A file that a config key names (a terrain image, mesh or MJCF file) could not be read.
    #[error("`{key}` = {:?}: {}: {}", file.display().to_string(), unreadable(source.io()), file.display())]
    FileUnreadable {
        /// Full key path.
        key: String,
        /// The file as the key names it.
        file: PathBuf,
        /// What the OS said.
        #[source]
        source: IoSource,
    },
    /// The file could not be read.
    #[error("cannot read config file {}: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// What the OS said.
        #[source]
        source: IoSource,
    },
}

/// An I/O error as the source of a [`ConfigError`]: shared, so that the error stays `Clone`, and
/// equal to another of the same kind and message, so that it stays `PartialEq`.
#[derive(Debug, Clone)]
pub struct IoSource(std::sync::Arc<std::io::Error>);

impl IoSource {
    /// The I/O error.
    pub fn io(&self) -> &std::io::Error {
        &self.0
    }
}

impl From<std::io::Error> for IoSource {
    fn from(e: std::io::Error) -> Self {
        Self(std::sync::Arc::new(e))
    }
}

impl PartialEq for IoSource {
    fn eq(&self, other: &Self) -> bool {
        self.0.kind() == other.0.kind() && self.0.to_string() == other.0.to_string()
    }
}

impl std::fmt::Display for IoSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for IoSource {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// The longest text of a value, key or file name that an error message echoes (characters).
pub const ECHO_LIMIT: usize = 200;

/// `text` cut to [`ECHO_LIMIT`] characters followed by `… (N bytes)` when it is longer, so
/// that an error never echoes a huge value whole (a 50 MB `run_name`).
pub fn shorten(text: &str) -> std::borrow::Cow<'_, str> {
    match text.char_indices().nth(ECHO_LIMIT) {
        None => std::borrow::Cow::Borrowed(text),
        Some((cut, _)) => std::borrow::Cow::Owned(format!("{}… ({} bytes)", &text[..cut], text.len())),
    }
}

/// [`shorten`] applied to every word of a message (a run of characters without white space):
/// a message that quotes names or values (a 100 KB joint name of a robot file) keeps its
/// sentences and echoes each at most [`ECHO_LIMIT`] characters.
pub fn shorten_words(text: &str) -> std::borrow::Cow<'_, str> {
    if text.split_whitespace().all(|w| w.chars().nth(ECHO_LIMIT).is_none()) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len().min(64 * ECHO_LIMIT));
    let mut rest = text;
    while !rest.is_empty() {
        let word_end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        out.push_str(&shorten(&rest[..word_end]));
        rest = &rest[word_end..];
        let space_end = rest.find(|c: char| !c.is_whitespace()).unwrap_or(rest.len());
        out.push_str(&rest[..space_end]);
        rest = &rest[space_end..];
    }
    std::borrow::Cow::Owned(out)
}

/// [`shorten`] applied to every line of a message (parser messages quote the offending line).
fn shorten_lines(text: &str) -> std::borrow::Cow<'_, str> {
    if text.lines().all(|l| l.chars().nth(ECHO_LIMIT).is_none()) {
        return std::borrow::Cow::Borrowed(text);
    }
    std::borrow::Cow::Owned(text.split('\n').map(|l| shorten(l).into_owned()).collect::<Vec<_>>().join("\n"))
}

/// Why a file cannot be read, in words (the OS message is the error's source).
fn unreadable(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "the file does not exist".to_string(),
        _ => format!("the file cannot be read ({e})"),
    }
}

impl ConfigError {
    pub(crate) fn invalid(key: &str, value: impl std::fmt::Display, allowed: impl Into<String>) -> Self {
        Self::InvalidValue { key: key.to_string(), value: value.to_string(), allowed: allowed.into() }
    }
}

/// The whole resolved configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub general: General,
    pub physics: Physics,
    pub safety: Safety,
    pub visual: Visual,
    pub snake: Snake,
    pub initial_state: InitialState,
    pub robot: Robot,
    pub ground: Ground,
    pub sensors: Sensors,
    pub control: Control,
    pub gait: Gait,
    pub terrain: Terrain,
    pub recording: Recording,
    pub plot: Plot,
    pub render: Render,
    pub video: Video,
    pub env: Env,
    pub legacy: Legacy,
    pub ros2: Ros2,
    pub estimation: Estimation,
    pub path_following: PathFollowing,
    pub follow_the_leader_reflex: FollowTheLeaderReflex,
    pub directional_admittance: DirectionalAdmittance,
    pub jam_resolution: JamResolution,
}

/// How the original tool's geometry is reproduced (`[legacy]`; user guide, "Use the original tool's config").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Legacy {
    pub geometry: LegacyGeometry,
}

/// `legacy.geometry`: which link shape and placement the snake gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LegacyGeometry {
    /// SimSerpent's links: each capsule spans exactly joint to joint (`snake.link_length_m`, end caps
    /// included), the body extends along the head's −x axis from the head tip at
    /// `snake.head_position_m`.
    NoOverlap,
    /// The original tool's links (thesis appendix 12.2): a capsule of core length
    /// `snake.link_length_m` between the two joints plus an end cap of `snake.link_radius_m` beyond
    /// each joint (neighbours overlap by 2 × radius), the body extending along +x (rotated by
    /// `snake.head_rotation_deg`) from the head, whose front joint point is at
    /// `head_position_m + (link_length_m, 0, 0)` as in listing 3.
    Faithful,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct General {
    pub run_name: String,
    pub output_dir: String,
    pub duration_secs: f64,
    pub timestep_secs: f64,
    pub integrator: Integrator,
    pub seed: u64,
    pub gravity_m_per_s2: [f64; 3],
    pub plot: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Integrator {
    Euler,
    RK4,
    #[serde(rename = "implicit")]
    Implicit,
    #[serde(rename = "implicitfast")]
    ImplicitFast,
}

impl Integrator {
    /// The MJCF attribute value.
    pub fn mjcf_name(self) -> &'static str {
        match self {
            Self::Euler => "Euler",
            Self::RK4 => "RK4",
            Self::Implicit => "implicit",
            Self::ImplicitFast => "implicitfast",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Physics {
    pub friction_cone: FrictionCone,
    pub self_collision: bool,
    pub contact_time_constant_secs: f64,
    pub contact_damping_ratio: f64,
    /// Direct contact stiffness (MuJoCo's solref in its direct form, `solref = (−k, −b)`), 1/s²;
    /// 0 = off (the time constant and damping ratio above are used).
    pub contact_stiffness_per_s2: f64,
    /// Direct contact damping b (1/s), used only with `contact_stiffness_per_s2 > 0`; 0 = none
    /// (an elastic contact: restitution close to 1).
    pub contact_damping_per_s: f64,
    pub solver_iterations: u32,
    /// Who computes the friction between links and the floor (and ground-like terrain).
    pub floor_friction: FloorFriction,
    /// `"stick_slip"` only: how the links' environment contacts (ground and obstacles) are solved
    /// (see `sim::ground`).
    pub environment_contact_solve: EnvironmentContactSolve,
    /// `"stick_slip"` only: time constant of the stick spring–damper that holds a link's contact
    /// point at rest (s; critically damped), or `"auto"`: max(5 ms, 5 timesteps) (see
    /// [`Config::floor_stick_time_constant_secs`]). Its presliding displacement is μ·g·τ².
    pub floor_stick_time_constant_secs: StickTimeConstant,
    /// Link–obstacle and link–ground contacts (floor, obstacles, terrain features): MuJoCo solref
    /// time constant (s), or `"auto"`: max(2 ms, 2 timesteps) (see
    /// [`Config::environment_contact_time_constant_secs`]).
    pub environment_contact_time_constant_secs: AutoSecs,
    /// Their damping ratio (MuJoCo solref; 1 = critically damped).
    pub environment_contact_damping_ratio: f64,
    /// Coefficient of restitution of SimSerpent's floor contact (`"stick_slip"`: the floor,
    /// slopes and boxes): the rebound speed over the impact speed of a link that lands flat. It
    /// sets the floor's damping, bounded by 0.5/timestep (see `sim::ground`); (0, 1].
    pub contact_restitution: f64,
    /// External forces on links, ramped from zero (`[[physics.external_forces]]`).
    pub external_forces: Vec<ExternalForce>,
}

/// A force on one link's centre of mass, ramped from zero (`[[physics.external_forces]]`): from
/// `start_secs` on it grows at `ramp_n_per_s` up to `force_n` (at once with a ramp of 0), along
/// `direction` (world frame, any length), and stops after `duration_secs` (0: never).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExternalForce {
    /// Link index, 0 = head.
    pub link: usize,
    pub direction: [f64; 3],
    pub start_secs: f64,
    pub ramp_n_per_s: f64,
    pub force_n: f64,
    pub duration_secs: f64,
}

impl ExternalForce {
    /// The force's magnitude (N) at time `t_secs`.
    pub fn magnitude_n(&self, t_secs: f64) -> f64 {
        let since = t_secs - self.start_secs;
        if since < 0.0 || (self.duration_secs > 0.0 && since >= self.duration_secs) {
            0.0
        } else if self.ramp_n_per_s > 0.0 {
            (self.ramp_n_per_s * since).min(self.force_n)
        } else {
            self.force_n
        }
    }
}

/// The friction law between links and ground (`physics.floor_friction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FloorFriction {
    /// MuJoCo's own friction constraints on the link–floor contacts (sliding contacts hop).
    Mujoco,
    /// Frictionless link–ground contacts (condim 1) for the normal force, and SimSerpent's
    /// elasto-plastic Coulomb law applied at each link's contact points before every step.
    StickSlip,
}

/// How SimSerpent's contact law solves the links' environment contacts
/// (`physics.environment_contact_solve`, `"stick_slip"` only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EnvironmentContactSolve {
    /// Each link's ground contacts from its own spring–damper and elasto-plastic friction (the
    /// link alone); obstacle contacts through the whole body's mobility, normals before friction.
    PerLink,
    /// Every ground and obstacle contact point's normal force and friction in one projected
    /// Gauss–Seidel solve through the whole body's mobility.
    WholeBody,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrictionCone {
    Elliptic,
    Pyramidal,
}

/// Divergence guards of the step loop (`[safety]`); see `sim::safety`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Safety {
    /// Stop the run when the kinetic energy per kilogram of robot exceeds this (J/kg); 0 = off.
    pub max_kinetic_energy_j_per_kg: f64,
    /// Evaluate the kinetic energy every this many steps (>= 1).
    pub check_every_n_steps: u64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Visual {
    pub show_contact_forces: bool,
    pub show_contact_points: bool,
    pub show_actuators: bool,
    pub show_joints: bool,
    pub show_center_of_mass: bool,
    pub make_transparent: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Snake {
    pub n_links: usize,
    pub link_length_m: f64,
    pub link_radius_m: f64,
    pub link_mass_kg: f64,
    pub joint_range_deg: f64,
    pub joint_damping_nm_s_per_rad: f64,
    pub joint_armature_kg_m2: f64,
    pub joint_axes: JointAxes,
    pub torque_range_nm: [f64; 2],
    pub ground_friction: [f64; 3],
    pub link_friction: [f64; 3],
    pub color_rgba: [f64; 4],
    pub head_position_m: [f64; 3],
    pub head_rotation_deg: [f64; 3],
}

impl Snake {
    /// Number of joints (= links - 1).
    pub fn n_joints(&self) -> usize {
        self.n_links.saturating_sub(1)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointAxes {
    Yaw,
    Alternating,
}

/// The state a run starts from beyond the snake's pose (`[initial_state]`): joint angles and
/// a velocity of the whole body (the thesis' experiment II set `data.qvel`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialState {
    /// Starting angle of every joint (joint_01 first), degrees; empty = the gait's own start.
    pub joint_angles_deg: Vec<f64>,
    /// Starting velocity of the head's frame origin (the head's front tip), world frame (m/s);
    /// the whole snake moves with it.
    pub linear_velocity_m_per_s: [f64; 3],
    /// Starting angular velocity of the whole snake about the head's front tip, world frame
    /// (rad/s).
    pub angular_velocity_rad_per_s: [f64; 3],
}

/// A user's robot (`run --robot FILE`, `[robot]`): its base and where it starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Robot {
    /// Give every root body of the robot that has no joint (a URDF's base link, an MJCF body
    /// without a joint) a free joint, so that it can move; false keeps it welded to the world.
    pub floating_base: bool,
    /// Translation of the whole robot from where its file puts it (m, world frame), applied
    /// after `rotation_deg`.
    pub position_m: [f64; 3],
    /// Rotation of the whole robot about the world origin, Euler angles about x, y, z (degrees,
    /// intrinsic x, then y, then z, as `snake.head_rotation_deg`).
    pub rotation_deg: [f64; 3],
    /// Move the robot up or down so that its lowest colliding geom just touches the floor
    /// (z = 0) at the start, whatever `position_m[2]` says.
    pub place_on_floor: bool,
    /// Give every hinge or slide joint of the robot that no actuator drives (every joint of a
    /// URDF, which has no actuators) a position servo: gains `control.position_kp_nm_per_rad`
    /// and `control.position_kv_nm_s_per_rad`, force range `snake.torque_range_nm`.
    pub position_servos: bool,
}

/// Friction between links and floor (`[ground]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ground {
    pub model: GroundModel,
    pub axial_friction: f64,
    pub lateral_friction: f64,
    pub backward_friction: f64,
    pub viscous_tangential_n_s_per_m: f64,
    pub viscous_normal_n_s_per_m: f64,
    /// Regions of the floor with their own friction (`[[ground.surfaces]]`; later entries win
    /// where they overlap). See [`surfaces`].
    pub surfaces: Vec<Surface>,
}

/// The ground friction model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GroundModel {
    Isotropic,
    Anisotropic,
    Directional,
    Viscous,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensors {
    pub noise_enabled: bool,
    pub accelerometer: SensorModel,
    pub gyro: SensorModel,
    /// The IMU's orientation (its `framequat`), rad: a small rotation of the true orientation.
    pub orientation: SensorModel,
    pub joint_angle: SensorModel,
    pub joint_velocity: SensorModel,
    pub actuator_torque: SensorModel,
    pub joint_force: SensorModel,
    pub joint_torque: SensorModel,
}

impl Sensors {
    /// The models by config key (`sensors.<key>`), in a fixed order.
    pub fn models(&self) -> [(&'static str, &SensorModel); 8] {
        [
            ("accelerometer", &self.accelerometer),
            ("gyro", &self.gyro),
            ("orientation", &self.orientation),
            ("joint_angle", &self.joint_angle),
            ("joint_velocity", &self.joint_velocity),
            ("actuator_torque", &self.actuator_torque),
            ("joint_force", &self.joint_force),
            ("joint_torque", &self.joint_torque),
        ]
    }
}

/// How one kind of sensor measures (`[sensors.<kind>]`): values in the kind's unit (m/s², rad/s,
/// rad, N·m or N; see `default.toml`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorModel {
    /// Standard deviation of the white Gaussian noise, per axis.
    pub std: f64,
    /// Constant bias added to every axis.
    pub bias: f64,
    /// Random-walk bias: standard deviation of its growth per √s (a Wiener process).
    pub bias_random_walk_per_sqrt_s: f64,
    /// Quantisation step (0 = none): readings are rounded to a multiple of it.
    pub resolution: f64,
    /// Sample rate (Hz, 0 = every step): a new sample when its period has passed, held in between.
    pub rate_hz: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Control {
    /// Which controller drives the joints: the configured gait, open loop, or the
    /// path-following controller of `[path_following]`.
    pub controller: ControllerKind,
    pub method: ControlMethod,
    pub torque_gear: f64,
    pub position_kp_nm_per_rad: f64,
    pub position_kv_nm_s_per_rad: f64,
    pub velocity_kv_nm_s_per_rad: f64,
    pub intvelocity_kp_nm_per_rad: f64,
    pub pid_kp_nm_per_rad: f64,
    pub pid_ki_nm_per_rad_s: f64,
    pub pid_kd_nm_s_per_rad: f64,
}

/// The controller of a run (`control.controller`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControllerKind {
    /// The `[gait]` trajectory, open loop (`control::TrajectoryController`).
    Gait,
    /// Line-of-sight path following (`control::PathFollowing`, `[path_following]`).
    PathFollowing,
    /// Kano & Ishiguro's decentralised follow-the-leader body with a lateral-pressure reflex
    /// (`control::FollowTheLeaderReflex`, `[follow_the_leader_reflex]`).
    FollowTheLeaderReflex,
    /// Shape-based directional admittance with a mode switch when wedged (Travers et al. 2018,
    /// Wang et al. 2020; `control::DirectionalAdmittance`, `[directional_admittance]`).
    DirectionalAdmittance,
    /// Propulsion-aware jam resolution through the contact Jacobian (Liljebäck et al.;
    /// `control::JamResolution`, `[jam_resolution]`).
    JamResolution,
}

/// Which actuator kind the controller drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControlMethod {
    Torque,
    Position,
    Velocity,
    Intvelocity,
}

impl ControlMethod {
    /// All kinds, in the order their actuators appear in the model (thesis 6.x: ctrl blocks).
    pub const ALL: [ControlMethod; 4] = [Self::Torque, Self::Position, Self::Velocity, Self::Intvelocity];

    /// Short name used in MJCF and column names.
    pub fn name(self) -> &'static str {
        match self {
            Self::Torque => "torque",
            Self::Position => "position",
            Self::Velocity => "velocity",
            Self::Intvelocity => "intvelocity",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gait {
    pub kind: GaitKind,
    pub ramp_secs: f64,
    pub sine_wave: SineWave,
    pub serpenoid: Serpenoid,
    pub sidewinding: Sidewinding,
    pub rolling: Rolling,
    pub form_closure: FormClosureGait,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GaitKind {
    None,
    SineWave,
    FormClosure,
    Serpenoid,
    Sidewinding,
    Rolling,
}

/// Hirose's serpenoid curve, discretised over the joints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Serpenoid {
    pub winding_angle_deg: f64,
    pub n_waves: f64,
    pub frequency_hz: f64,
    pub offset_deg: f64,
}

/// Sidewinding: two travelling waves, on the yaw and on the pitch joints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sidewinding {
    pub yaw_amplitude_deg: f64,
    pub pitch_amplitude_deg: f64,
    pub frequency_hz: f64,
    pub phase_lag_deg: f64,
    pub pitch_phase_deg: f64,
}

/// Lateral rolling: an arc turning about the body axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rolling {
    pub amplitude_deg: f64,
    pub frequency_hz: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SineWave {
    pub amplitude_deg: f64,
    pub frequency_hz: f64,
    pub phase_lag_deg: f64,
    pub offset_deg: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormClosureGait {
    pub pattern_deg: Vec<f64>,
    pub shift_period_secs: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Terrain {
    pub kind: TerrainKind,
    pub obstacle_friction: [f64; 3],
    pub cylinder_height_m: f64,
    pub floor_size_m: f64,
    pub two_cylinders: TwoCylinders,
    pub random_cylinders: RandomCylinders,
    pub cylinder_path: CylinderPath,
    pub form_closure: FormClosureTerrain,
    /// A third-party MJCF terrain file included into the scene (`""` = none).
    pub include_mjcf: String,
    /// Box walls.
    pub walls: Vec<Wall>,
    /// Obstacles from STL/OBJ meshes (collided as their convex hull).
    pub mesh_obstacles: Vec<MeshObstacle>,
    pub pegboard: Pegboard,
    pub channel: Channel,
    pub slope: Slope,
    pub heightfield: Heightfield,
    pub mesh_terrain: MeshTerrain,
}

/// One box wall between two points of the floor (`terrain.walls`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    /// Centre line from `start_m` to `end_m` (xy, world).
    pub start_m: [f64; 2],
    pub end_m: [f64; 2],
    pub height_m: f64,
    pub thickness_m: f64,
}

/// An obstacle mesh (`terrain.mesh_obstacles`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshObstacle {
    /// STL (binary or ASCII) or OBJ file.
    pub file: String,
    /// Where the mesh's own origin goes (world).
    pub position_m: [f64; 3],
    /// Euler angles about x, y, z (degrees), as `snake.head_rotation_deg`; optional, default
    /// `[0, 0, 0]` (the file's orientation).
    #[serde(default)]
    pub rotation_deg: [f64; 3],
    /// Uniform scale of the file's coordinates (to metres); optional, default 1 (the file is in
    /// metres).
    #[serde(default = "unit_scale")]
    pub scale: f64,
}

fn unit_scale() -> f64 {
    1.0
}

/// Peg layouts (`terrain.pegboard.layout`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PegLayout {
    None,
    Square,
    Hexagonal,
    Random,
}

/// A board of pegs (`[terrain.pegboard]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pegboard {
    pub layout: PegLayout,
    pub peg_radius_m: f64,
    pub peg_height_m: f64,
    pub spacing_m: f64,
    pub region_min_m: [f64; 2],
    pub region_max_m: [f64; 2],
    pub count: usize,
    pub skip_pegs_on_snake: bool,
}

/// Two parallel walls around a centre line (`[terrain.channel]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Channel {
    pub enabled: bool,
    pub start_m: [f64; 2],
    pub end_m: [f64; 2],
    pub width_m: f64,
    pub height_m: f64,
    pub thickness_m: f64,
}

/// A tilted plane region (ramp) rising from the floor (`[terrain.slope]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Slope {
    pub angle_deg: f64,
    pub start_m: [f64; 2],
    pub direction_deg: f64,
    pub length_m: f64,
    pub width_m: f64,
}

/// A heightfield from a grayscale image (`[terrain.heightfield]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Heightfield {
    pub file: String,
    pub center_m: [f64; 2],
    pub size_x_m: f64,
    pub size_y_m: f64,
    pub height_m: f64,
    pub base_m: f64,
}

/// A (non-convex) terrain mesh rasterised into a heightfield (`[terrain.mesh_terrain]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshTerrain {
    pub file: String,
    pub position_m: [f64; 3],
    pub scale: f64,
    pub resolution_m: f64,
    pub base_m: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TerrainKind {
    None,
    TwoCylinders,
    RandomCylinders,
    CylinderPath,
    FormClosure,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwoCylinders {
    pub distance_m: f64,
    pub radius_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomCylinders {
    pub count: usize,
    pub radius_range_m: [f64; 2],
    pub half_size_m: f64,
    pub min_gap_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderPath {
    pub n_pairs: usize,
    pub spacing_m: f64,
    pub width_m: f64,
    pub radius_m: f64,
    pub start_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormClosureTerrain {
    pub order: u8,
    pub radius_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recording {
    pub enabled: bool,
    pub every_n_steps: u64,
    pub format: TableFormat,
    pub parquet_row_group_rows: usize,
    pub parquet_rows_per_file: u64,
    pub parquet_compression: ParquetCompression,
    pub link_position: bool,
    pub link_orientation: bool,
    pub link_velocity: bool,
    pub link_acceleration: bool,
    pub link_angular_velocity: bool,
    pub link_angular_acceleration: bool,
    pub joint_angles: bool,
    pub joint_velocities: bool,
    pub torque_actuator_forces: bool,
    pub position_actuator_forces: bool,
    pub velocity_actuator_forces: bool,
    pub intvelocity_actuator_forces: bool,
    pub external_contact_forces: bool,
    pub internal_joint_forces: bool,
    pub imu_sensors: bool,
    pub contacts: bool,
}

/// File formats of the recording (`recording.format`): CSV tables, Parquet tables and/or one
/// ROS 2 bag (MCAP). Written in the config as one name (`"csv"`, `"parquet"`, `"both"` = CSV and
/// Parquet, `"mcap"`) or a list of names (`["csv", "mcap"]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableFormat {
    csv: bool,
    parquet: bool,
    mcap: bool,
}

// The single-format values keep the names they had as enum variants.
#[allow(non_upper_case_globals)]
impl TableFormat {
    /// CSV only.
    pub const Csv: Self = Self { csv: true, parquet: false, mcap: false };
    /// Parquet only (needs the `parquet` cargo feature).
    pub const Parquet: Self = Self { csv: false, parquet: true, mcap: false };
    /// CSV and Parquet, same columns.
    pub const Both: Self = Self { csv: true, parquet: true, mcap: false };
    /// A ROS 2 bag (MCAP) only.
    pub const Mcap: Self = Self { csv: false, parquet: false, mcap: true };

    /// The names a config may use, in the order they are written back.
    const NAMES: [&'static str; 3] = ["csv", "parquet", "mcap"];
    const EXPECTED: &'static str = "one of \"csv\", \"parquet\", \"both\" (CSV and Parquet), \"mcap\" (a ROS 2 bag), or a list of them such as [\"csv\", \"mcap\"]";

    /// Whether CSV files are written.
    pub fn csv(self) -> bool {
        self.csv
    }

    /// Whether Parquet files are written.
    pub fn parquet(self) -> bool {
        self.parquet
    }

    /// Whether a ROS 2 bag (`run.mcap`) is written.
    pub fn mcap(self) -> bool {
        self.mcap
    }

    /// The same formats, and a ROS 2 bag besides.
    pub fn with_mcap(self) -> Self {
        Self { mcap: true, ..self }
    }

    fn flags(self) -> [bool; 3] {
        [self.csv, self.parquet, self.mcap]
    }

    fn add(&mut self, name: &str) -> bool {
        match name {
            "csv" => self.csv = true,
            "parquet" => self.parquet = true,
            "both" => (self.csv, self.parquet) = (true, true),
            "mcap" => self.mcap = true,
            _ => return false,
        }
        true
    }
}

impl std::fmt::Display for TableFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = Self::NAMES.iter().zip(self.flags()).filter(|(_, on)| *on).map(|(n, _)| *n).collect();
        match names.as_slice() {
            [one] => write!(f, "{one}"),
            ["csv", "parquet"] => write!(f, "both"),
            many => write!(f, "[{}]", many.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ")),
        }
    }
}

impl Serialize for TableFormat {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let names: Vec<&str> = Self::NAMES.iter().zip(self.flags()).filter(|(_, on)| *on).map(|(n, _)| *n).collect();
        match names.as_slice() {
            [one] => serializer.serialize_str(one),
            ["csv", "parquet"] => serializer.serialize_str("both"),
            many => many.serialize(serializer),
        }
    }
}

impl<'de> Deserialize<'de> for TableFormat {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = TableFormat;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(TableFormat::EXPECTED)
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<TableFormat, E> {
                let mut format = TableFormat { csv: false, parquet: false, mcap: false };
                if format.add(v) { Ok(format) } else { Err(E::invalid_value(serde::de::Unexpected::Str(v), &self)) }
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<TableFormat, A::Error> {
                use serde::de::Error;
                let mut format = TableFormat { csv: false, parquet: false, mcap: false };
                let mut seen = Vec::new();
                /// One name in the list: its error says which names there are.
                struct Name(String);
                impl<'de> Deserialize<'de> for Name {
                    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                        struct NameVisitor;
                        impl serde::de::Visitor<'_> for NameVisitor {
                            type Value = Name;
                            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                                f.write_str("a format name: \"csv\", \"parquet\", \"both\" or \"mcap\"")
                            }
                            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Name, E> {
                                Ok(Name(v.to_string()))
                            }
                        }
                        deserializer.deserialize_str(NameVisitor)
                    }
                }
                while let Some(Name(name)) = seq.next_element::<Name>()? {
                    if !format.add(&name) {
                        return Err(A::Error::invalid_value(serde::de::Unexpected::Str(&name), &self));
                    }
                    if seen.contains(&name) {
                        return Err(A::Error::custom(format!("\"{name}\" is listed twice")));
                    }
                    seen.push(name);
                }
                if seen.is_empty() {
                    return Err(A::Error::invalid_length(0, &self));
                }
                Ok(format)
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

/// Compression of the Parquet tables (`recording.parquet_compression`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParquetCompression {
    /// LZ4 (the `LZ4_RAW` codec): fast, small memory.
    Lz4,
    /// Zstandard: the smallest files, the most memory while writing.
    Zstd,
    /// Snappy: what older readers expect.
    Snappy,
    /// No compression.
    None,
}

/// Plots of a run (`[plot]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plot {
    pub width_px: u32,
    pub height_px: u32,
}

/// Offscreen pictures (`[render]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Render {
    pub width_px: u32,
    pub height_px: u32,
    pub quality: RenderQuality,
    pub camera: CameraKind,
    pub camera_distance_m: f64,
    pub camera_azimuth_deg: f64,
    pub camera_elevation_deg: f64,
    pub fixed_lookat_m: [f64; 3],
    pub time_overlay: bool,
    pub image_times_secs: Vec<f64>,
    pub image_cameras: Vec<CameraKind>,
    pub record_state: bool,
}

/// Rendering effects (`render.quality`): speed against looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RenderQuality {
    /// No shadows, reflections or anti-aliasing.
    Fast,
    /// Small shadow map, no reflections or anti-aliasing.
    Medium,
    /// MuJoCo's defaults (large shadow map, reflections, 4x anti-aliasing).
    Full,
}

/// Where a picture is taken from (`render.camera`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CameraKind {
    /// Tracks the head at the configured distance, azimuth and elevation.
    Follow,
    /// Tracks the head from straight above.
    Top,
    /// Looks at `render.fixed_lookat_m` and does not move.
    Fixed,
}

impl CameraKind {
    /// Short name (file names, messages).
    pub fn name(self) -> &'static str {
        match self {
            Self::Follow => "follow",
            Self::Top => "top",
            Self::Fixed => "fixed",
        }
    }
}

/// Video of a run (`[video]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Video {
    pub enabled: bool,
    pub format: VideoFormat,
    pub frames_per_sec: f64,
    pub playback_speed: f64,
}

/// Video container (`video.format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VideoFormat {
    /// H.264 in MP4 through an `ffmpeg` subprocess.
    Mp4,
    /// Animated GIF, built in.
    Gif,
}

/// The reinforcement-learning environment (`[env]`; see `crate::env`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Env {
    /// Layout of the observation vector (1 is the only one).
    pub observation_version: u32,
    /// Per link IMU readings in the observation.
    pub observe_imu: bool,
    /// Per joint force/torque sensor readings in the observation.
    pub observe_joint_force_torque: bool,
    /// Per link contact estimates (`[estimation]`) in the observation.
    pub observe_contact_estimates: bool,
    /// What an action is.
    pub action: EnvAction,
    /// Time between two actions (s), a whole number of timesteps.
    pub control_period_secs: f64,
    /// Episode length (s): reaching it truncates the episode.
    pub max_episode_secs: f64,
    /// Weight of the forward progress (per m).
    pub reward_forward_weight: f64,
    /// Weight of the actuator energy (per J).
    pub reward_energy_weight: f64,
    /// Weight of the largest contact normal force (per N).
    pub reward_contact_force_weight: f64,
    /// Terminate when a contact normal force exceeds this (N); 0 = never.
    pub terminate_contact_force_n: f64,
    /// Weight of the control cost Σ action² (per action unit², of the normalised action when
    /// `normalize_action`), as Gymnasium's MuJoCo suite.
    pub reward_ctrl_cost_weight: f64,
    /// Reset noise of the joint angles (uniform in ±scale, rad) and joint velocities
    /// (scale · standard normal, rad/s), as Gymnasium's `reset_noise_scale`; 0 = none.
    pub reset_noise_scale: f64,
    /// Reset noise of the snake's heading (uniform in ± this, rad, about the vertical); 0 = none.
    pub reset_heading_noise_rad: f64,
    /// Leave the head's absolute x and y out of the observation (Gymnasium's
    /// `exclude_current_positions_from_observation`).
    pub exclude_current_positions_from_observation: bool,
    /// Actions in [-1, 1] (float32 in Python), mapped linearly onto the physical bounds.
    pub normalize_action: bool,
    /// Physics settings of the environment: the config's own, or a measured faster set.
    pub preset: EnvPreset,
}

/// Physics settings of an environment (`env.preset`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EnvPreset {
    /// The config's `[general]` and `[physics]` as written.
    Default,
    /// Faster physics for reinforcement learning (see `ENV_FAST_PRESET`).
    Fast,
}

/// The overrides `env.preset = "fast"` applies on top of the config (keys as `--set`),
/// chosen from measurements (BENCHMARKS.md, "The `fast` preset on the merged defaults"):
/// implicitfast at 5 ms (4 physics steps per 20 ms action instead of 20 RK4 steps; the
/// timestep-dependent "auto" settings follow: floor stick time constant 25 ms, environment
/// contacts 10 ms). Over 64 starts the reference gait's mean speed, heading and peak contact
/// force stay within 5 % of the default physics (+0.2 %, +0.012 rad, +1.6 %); at 10 ms (faster)
/// the mean peak contact force rose by 10.7 %.
pub const ENV_FAST_PRESET: &[&str] = &["general.integrator=\"implicitfast\"", "general.timestep_secs=0.005"];

/// What an action of the environment is (`env.action`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EnvAction {
    /// Joint target angles (rad) for the position servos.
    Position,
    /// Joint torques (N·m) for the torque motors.
    Torque,
}

impl EnvAction {
    /// The actuator kind the model must drive.
    pub fn control_method(self) -> ControlMethod {
        match self {
            Self::Position => ControlMethod::Position,
            Self::Torque => ControlMethod::Torque,
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        // The embedded default is checked by a unit test; it cannot fail to parse.
        load_config_str(DEFAULT_CONFIG_TOML, ConfigSource::Toml, &[])
            .unwrap_or_else(|e| unreachable!("embedded default config is invalid: {e}"))
    }
}

impl Config {
    /// Full length of one link's capsule, end caps included (m): `snake.link_length_m` for
    /// `legacy.geometry = "no_overlap"`, `link_length_m + 2 × link_radius_m` for `"faithful"`.
    pub fn link_capsule_length_m(&self) -> f64 {
        match self.legacy.geometry {
            LegacyGeometry::NoOverlap => self.snake.link_length_m,
            LegacyGeometry::Faithful => self.snake.link_length_m + 2.0 * self.snake.link_radius_m,
        }
    }

    /// The resolved config as TOML (written to every run folder).
    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# cannot serialize config: {e}\n"))
    }

    /// Snake joint angle limit in radians.
    pub fn joint_range_rad(&self) -> f64 {
        self.snake.joint_range_deg.to_radians()
    }
}

/// Contact estimation in the step loop (`[estimation]`; `estimation::MotionEstimator`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Estimation {
    /// Run the estimator at every sensed step: estimates in `Observation::contacts` and the
    /// `estimates` table.
    pub enabled: bool,
    /// Where the link orientations come from: the encoders and the head IMU, or the simulator.
    pub orientation: OrientationSource,
    /// Horizontal obstacle force (N) from which a link counts as touching an obstacle.
    pub detection_threshold_n: f64,
    /// Smallest lateral obstacle force (N) for which a contact point along the link is reported.
    pub min_lateral_force_n: f64,
    /// With MuJoCo's floor friction: below this speed (m/s) a link's floor contact point counts
    /// as sticking (the `stick_slip` floor's stick springs decide otherwise).
    pub sliding_speed_m_per_s: f64,
    /// Gain (1/s) of the head attitude filter's tilt correction from the accelerometer.
    pub tilt_gain_per_s: f64,
    /// Time constant (s) of the contact point's least-squares filter over the recent steps of a
    /// contact (0 = every step on its own).
    pub contact_point_filter_secs: f64,
    /// Where the floor's Coulomb coefficients come from: `[ground]` or identified online.
    pub friction: FloorFrictionSource,
    /// Identification: the starting value of every coefficient (the prior).
    pub friction_prior: f64,
    /// Identification: time constant (s) of the forgetting factor (older link-steps weigh less).
    pub friction_window_secs: f64,
    /// Separate self-contacts (link–link) from obstacle forces, from the body's shape (encoders).
    pub self_contacts: bool,
    /// Two links count as touching when the shape puts their capsules at most this far apart (m).
    pub self_contact_margin_m: f64,
}

/// `estimation.friction`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FloorFrictionSource {
    /// The coefficients of `[ground]` (known μ).
    Config,
    /// Recursive least squares on the link-steps that only the floor explains.
    Identify,
}

/// `estimation.orientation`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OrientationSource {
    /// Head attitude from its gyro and accelerometer (measured), the rest from the encoders.
    Imu,
    /// The simulator's link orientations and velocities (for comparison).
    True,
}

/// The path-following controller (`[path_following]`; `control::PathFollowing`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathFollowing {
    /// The path: the points (world x, y, m) it passes through, in order. Two points: a straight
    /// line through both; more: waypoints joined by straight segments.
    pub waypoints_m: Vec<[f64; 2]>,
    /// Look-ahead distance Δ of the line-of-sight guidance (m).
    pub lookahead_m: f64,
    /// Heading gain k_θ: joint offset (rad) per radian of heading error.
    pub heading_gain: f64,
    /// Largest joint offset (degrees).
    pub max_offset_deg: f64,
    /// A waypoint counts as reached within this distance of the centre of mass (m).
    pub acceptance_radius_m: f64,
}

/// The decentralised follow-the-leader body with a lateral-pressure reflex
/// (`[follow_the_leader_reflex]`; `control::FollowTheLeaderReflex`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FollowTheLeaderReflex {
    /// Which contacts the reflex reads.
    pub contacts: ContactSource,
    /// Whether the contacts feed the law (false: the `[gait.sine_wave]` wave alone).
    pub feedback: bool,
    /// The goal direction (degrees from +x): a contact force with a component along it is
    /// propulsive, one against it resisting.
    pub goal_heading_deg: f64,
    /// Heading hold (`control::HeadingHold`): gait offset φ₀ (rad) per radian of the mean link
    /// heading's deviation from the goal (0 = off; independent of `feedback`).
    pub heading_gain: f64,
    /// Largest heading-hold offset φ₀ (degrees).
    pub heading_max_offset_deg: f64,
    /// Bend toward a peg on the propulsive flank: joint offset (rad) per newton of lateral force.
    pub propulsive_gain_rad_per_n: f64,
    /// Relax away from a peg on the resisting flank: joint offset (rad) per newton.
    pub resisting_gain_rad_per_n: f64,
    /// Time constant (s) of the low-pass filter on each link's contact force.
    pub force_filter_secs: f64,
    /// Largest offset of one joint (degrees).
    pub max_offset_deg: f64,
}

/// Shape-based directional admittance (`[directional_admittance]`;
/// `control::DirectionalAdmittance`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalAdmittance {
    /// Which contacts the law reads.
    pub contacts: ContactSource,
    /// Whether the contacts feed the law (false: the `[gait.sine_wave]` wave alone).
    pub feedback: bool,
    /// The goal direction (degrees from +x).
    pub goal_heading_deg: f64,
    /// Heading hold (`control::HeadingHold`): gait offset φ₀ (rad) per radian of the mean link
    /// heading's deviation from the goal (0 = off; independent of `feedback`).
    pub heading_gain: f64,
    /// Largest heading-hold offset φ₀ (degrees).
    pub heading_max_offset_deg: f64,
    /// Number of body windows, each with its own wave amplitude.
    pub windows: usize,
    /// Width (standard deviation, in joints) of each window's Gaussian.
    pub window_sigma_joints: f64,
    /// Stiffness K of the amplitude admittance (N·m per rad of amplitude).
    pub stiffness_nm_per_rad: f64,
    /// Damping B of the amplitude admittance (N·m·s per rad of amplitude).
    pub damping_nm_s_per_rad: f64,
    /// Bounds of each window's amplitude (degrees).
    pub min_amplitude_deg: f64,
    pub max_amplitude_deg: f64,
    /// Wedged: the filtered resisting force above `wedge_force_n` (N) while the filtered
    /// progress speed is below `wedge_speed_m_per_s` (m/s) for `wedge_secs` (s).
    pub wedge_force_n: f64,
    pub wedge_speed_m_per_s: f64,
    pub wedge_secs: f64,
    /// Time constant (s) of the low-pass filters on the resisting force and the speed.
    pub filter_secs: f64,
    /// The escape mode (after a wedge): every contact, propulsive or resisting, is complied to,
    /// with the stiffness scaled by `escape_stiffness_ratio`, for `escape_secs` (s).
    pub escape_stiffness_ratio: f64,
    pub escape_secs: f64,
}

/// Propulsion-aware jam resolution (`[jam_resolution]`; `control::JamResolution`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JamResolution {
    /// Which contacts the law reads.
    pub contacts: ContactSource,
    /// Whether the contacts feed the law (false: the `[gait.sine_wave]` wave alone).
    pub feedback: bool,
    /// The goal direction (degrees from +x).
    pub goal_heading_deg: f64,
    /// Heading hold (`control::HeadingHold`): gait offset φ₀ (rad) per radian of the mean link
    /// heading's deviation from the goal (0 = off; independent of `feedback`).
    pub heading_gain: f64,
    /// Largest heading-hold offset φ₀ (degrees).
    pub heading_max_offset_deg: f64,
    /// A jam: the centre of mass gains less than `jam_min_progress_m` (m) along the goal
    /// within `jam_window_secs` (s).
    pub jam_window_secs: f64,
    pub jam_min_progress_m: f64,
    /// How long (s) a resolution acts once a jam is detected.
    pub resolve_secs: f64,
    /// The total contact force (N) the joint-torque increments ask of the propelling contacts.
    pub push_force_n: f64,
    /// A contact can propel when its normal's component along the goal is at least this
    /// (cosine, 0..1).
    pub min_propulsion: f64,
    /// Time constant (s) of the joint offsets toward their target.
    pub offset_filter_secs: f64,
    /// Largest offset of one joint (degrees).
    pub max_offset_deg: f64,
}

/// Where a contact-feeling controller reads its contacts (`follow_the_leader_reflex.contacts`, …).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactSource {
    /// The step loop's estimates (`Observation::contacts`, needs `estimation.enabled = true`).
    Estimated,
    /// The simulator's obstacle forces and contact points (for comparison).
    True,
    /// The simulator's obstacle forces and the other links' (self-contact) forces together, as
    /// one obstacle force per link: what an exact estimator that cannot tell self-contacts from
    /// obstacles would report (for comparison: how much a law reacts to its own body).
    TrueWithSelf,
}

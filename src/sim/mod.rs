//! The engine: compiling models and stepping them. MuJoCo's state is private to this module;
//! everything else reads it through [`World`]'s accessors or a [`Snapshot`].
//!
//! [`World`] holds the compiled model, the engine state and the resolved [`Index`].
//! [`Simulation`] owns the only step loop ([`Simulation::run`]): sense → controller → actuators →
//! ground → (record) → observers → `mj_step` → checks, with [`Observer`]s hooked in at the start,
//! every step, every recorded step and the end (see ARCHITECTURE.md, "Order of work in a step").

mod compile;
mod external;
pub mod fatal;
mod ground;
mod index;
mod noise;
mod robot;
mod safety;
mod snapshot;
mod step_loop;

pub use crate::state::{ContactRow, GeomClass, Snapshot};
pub use ground::{Ground, OwnContact};
pub use index::{Index, JointIndex, LinkIndex};
pub use noise::SensorNoise;
pub use safety::EnergyGuard;
pub use step_loop::{Every, LoopPlan, Observer, Simulation, SimulationState, StepView};

use crate::config::{Config, ControlMethod};
use crate::control::{Command, Observation};
use crate::model::{self, GeneratedModel};
use crate::state;
use mujoco_rs::prelude::*;
use std::path::Path;

/// Errors of building or running a world.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The configuration is inconsistent (exit code 2).
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// MuJoCo rejected a model, or a model lacks what the run needs.
    #[error("model: {}", crate::config::shorten_words(.0))]
    Model(String),
    /// MuJoCo rejected the model generated from a validated config (a range that validation
    /// does not know, or a third-party terrain): bad input, like [`SimError::Config`].
    #[error("MuJoCo rejected {}: {}", crate::config::shorten_words(what), crate::config::shorten_words(message))]
    ModelRejected {
        /// Which model: "the generated model", "the model with the third-party terrain FILE".
        what: String,
        /// MuJoCo's whole message, naming the user's files (not scratch copies).
        message: String,
    },
    /// A scratch file or folder for compiling a model could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file or folder.
        path: std::path::PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A user's robot file could not be used.
    #[error("robot file {}: {}", crate::config::shorten(file), crate::config::shorten_words(message))]
    RobotFile {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The simulation became unstable.
    #[error("simulation diverged at t = {time_secs:.6} s (step {step}): {what}")]
    Diverged {
        /// Simulated time.
        time_secs: f64,
        /// Step number.
        step: u64,
        /// What blew up.
        what: String,
    },
    /// SIGINT/SIGTERM (or [`crate::interrupt::request`]) stopped the work (exit code 130).
    #[error("interrupted by a signal (SIGINT or SIGTERM) {at}")]
    Interrupted {
        /// Where: "at t = 1.2 s (step 1200) of case X", "before case X".
        at: String,
    },
}

/// MuJoCo's version string (for manifests and reports).
pub fn engine_version() -> String {
    mujoco_rs::mujoco_version().to_string()
}

/// The version of the `mujoco-rs` binding (pinned exactly in Cargo.toml).
pub const BINDING_VERSION: &str = "7.0.0";

/// A shape fixed to the world, seen from above (for plots): circles for cylinders, spheres
/// and capsules, axis-aligned rectangles for boxes (x, y: centre; r, hx, hy: radius and half
/// sizes; m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlanarShape {
    /// A cylinder, sphere or capsule.
    Circle { x: f64, y: f64, r: f64 },
    /// A box.
    Rect { x: f64, y: f64, hx: f64, hy: f64 },
}

/// The shapes of the geoms fixed to the world body of the model in `model_xml` (a run folder's
/// `model.xml`), seen from above.
pub fn world_body_shapes(model_xml: &Path) -> Result<Vec<PlanarShape>, SimError> {
    let model = MjModel::from_xml(model_xml)
        .map_err(|e| SimError::Model(format!("MuJoCo cannot load {} ({e})", model_xml.display())))?;
    let mut out = Vec::new();
    let (types, bodies, sizes, pos) = (model.geom_type(), model.geom_bodyid(), model.geom_size(), model.geom_pos());
    for g in 0..types.len() {
        if bodies[g] != 0 {
            continue;
        }
        let (p, s) = (pos[g], sizes[g]);
        match types[g] {
            MjtGeomBase::mjGEOM_CYLINDER | MjtGeomBase::mjGEOM_SPHERE | MjtGeomBase::mjGEOM_CAPSULE => {
                out.push(PlanarShape::Circle { x: p[0], y: p[1], r: s[0] })
            }
            MjtGeomBase::mjGEOM_BOX => out.push(PlanarShape::Rect { x: p[0], y: p[1], hx: s[0], hy: s[1] }),
            _ => {}
        }
    }
    Ok(out)
}

/// A fresh, private scratch folder in the system's temp dir (`$TMPDIR`): a random name created
/// exclusively (never an existing folder or a planted symbolic link), mode 0700 on Unix, and
/// removed with everything in it when the returned guard is dropped — on success, on error and
/// on a panic that unwinds. A SIGINT/SIGTERM only sets the run's interrupt flag, so the folder
/// is removed too; only SIGKILL (or a crash inside MuJoCo) leaves it behind.
///
/// # Errors
/// [`SimError::Write`] when the temp dir is not writable.
pub fn scratch_dir(what: &str) -> Result<Scratch, SimError> {
    let prefix = format!("simserpent-{what}-");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix);
    // Created with this mode (mkdir(2)), not chmod-ed afterwards: never readable by others.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o700));
    let dir = builder.tempdir().map_err(|source| SimError::Write { path: std::env::temp_dir(), source })?;
    // A fatal MuJoCo error ends the process without running destructors: it removes the
    // scratch folders registered here first (see `fatal`).
    fatal::register_scratch(dir.path().to_path_buf());
    Ok(Scratch(dir))
}

/// A scratch folder of [`scratch_dir`], removed with everything in it when dropped.
#[derive(Debug)]
pub struct Scratch(tempfile::TempDir);

impl Scratch {
    /// The folder.
    pub fn path(&self) -> &Path {
        self.0.path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        fatal::unregister_scratch(self.0.path());
    }
}

/// [`SimError::Write`] for `path`.
fn write_err(path: &Path) -> impl Fn(std::io::Error) -> SimError + '_ {
    move |source| SimError::Write { path: path.to_path_buf(), source }
}

/// The third-party terrain's source file among `copies`, for error messages.
fn user_terrain_source(copies: &[model::features::FileCopy]) -> String {
    copies
        .iter()
        .find(|c| c.dest == model::features::USER_TERRAIN_FILE)
        .map_or_else(String::new, |c| c.source.display().to_string())
}

/// Copies one terrain source into `dir` (at `copy.dest`, creating its sub-folders). The source
/// is read again as at its check: a regular file (after following symbolic links), no more than
/// `copy.max_bytes` — a file replaced or grown since it was checked is an error of its config
/// key, never a copy of a device or an endless one.
///
/// # Errors
/// [`SimError::Config`] (the key and the file) when the source is missing, not a regular file or
/// too large; [`SimError::Write`] when the copy cannot be written.
pub fn copy_file(dir: &Path, copy: &model::features::FileCopy) -> Result<(), SimError> {
    use model::files::ReadError;
    let source_text = copy.source.display().to_string();
    let read_err = |e: ReadError| SimError::Config(e.for_key(&copy.key, &source_text));
    let mut reader = model::files::open_regular_file(&copy.source, copy.max_bytes).map_err(read_err)?;
    let dest = dir.join(&copy.dest);
    if let Some(parent) = dest.parent() {
        std::fs::create_dir_all(parent).map_err(write_err(parent))?;
    }
    let mut out = std::fs::File::create(&dest).map_err(write_err(&dest))?;
    // io::copy does not say which side failed: read into a buffer and write it ourselves.
    let mut buf = vec![0u8; 64 * 1024];
    let mut total: u64 = 0;
    loop {
        let n = match std::io::Read::read(&mut reader, &mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(source) => return Err(read_err(ReadError::Io { path: copy.source.clone(), source })),
        };
        total += n as u64;
        if total > copy.max_bytes {
            drop(out);
            let _ = std::fs::remove_file(&dest);
            return Err(read_err(ReadError::TooLarge {
                path: copy.source.clone(),
                size_bytes: total,
                cap_bytes: copy.max_bytes,
            }));
        }
        std::io::Write::write_all(&mut out, &buf[..n]).map_err(write_err(&dest))?;
    }
    Ok(())
}

/// Writes `model.xml`, the texts and the copies into `dir` (as in a run folder); returns the
/// path of `model.xml`.
///
/// # Errors
/// As [`copy_file`]; [`SimError::Write`] for the texts.
pub fn write_model_folder(
    dir: &Path,
    model_xml: &str,
    texts: &[(String, String)],
    copies: &[model::features::FileCopy],
) -> Result<std::path::PathBuf, SimError> {
    for c in copies {
        copy_file(dir, c)?;
    }
    for (name, text) in texts {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(write_err(&path))?;
    }
    let path = dir.join("model.xml");
    std::fs::write(&path, model_xml).map_err(write_err(&path))?;
    Ok(path)
}

impl From<model::ModelError> for SimError {
    fn from(e: model::ModelError) -> Self {
        match e {
            model::ModelError::Config(c) => SimError::Config(c),
            other => SimError::Model(other.to_string()),
        }
    }
}

/// The deepest a robot may start inside the floor, an obstacle or the terrain (m): resting
/// contact at the start is fine, a placement error is not (see [`World::check_start_clear`]).
pub const START_PENETRATION_TOLERANCE_M: f64 = 0.5e-3;

/// A contact point of [`World::point_frame_jacobians`]: its body, its position (world frame) and
/// three unit directions.
pub(crate) type PointFrame = (usize, [f64; 3], [[f64; 3]; 3]);

/// Reusable buffers of [`World::point_mobility`].
#[derive(Debug, Clone, Default)]
pub(crate) struct MobilityBuffers {
    nv: usize,
    /// M⁻¹ (nv × nv) and the identity it is solved from ([`World::point_frame_jacobians`]).
    minv: Vec<f64>,
    identity: Vec<f64>,
    jac: Vec<f64>,
    jt: Vec<f64>,
    minv_jt: Vec<f64>,
    /// The rows' mobility matrix (n × n, row-major).
    pub w: Vec<f64>,
    /// The rows' accelerations in the forward pass.
    pub acc: Vec<f64>,
}

impl MobilityBuffers {
    /// Degrees of freedom of the latest [`World::point_frame_jacobians`].
    pub fn nv(&self) -> usize {
        self.nv
    }

    /// Row r's Jacobian d_rᵀ·J_r (nv numbers) of the latest [`World::point_frame_jacobians`].
    pub fn jacobian(&self, r: usize) -> &[f64] {
        &self.jt[r * self.nv..(r + 1) * self.nv]
    }

    /// M⁻¹·J_rᵀ·d_r (nv numbers): the joint-space acceleration a unit force along row r causes.
    pub fn response(&self, r: usize) -> &[f64] {
        &self.minv_jt[r * self.nv..(r + 1) * self.nv]
    }

    /// Point i's three rows' Jacobians (3·nv numbers, row after row).
    pub fn point_jacobians(&self, i: usize) -> &[f64] {
        &self.jt[3 * i * self.nv..3 * (i + 1) * self.nv]
    }

    /// Point i's three rows' responses M⁻¹·Jᵀ·d (3·nv numbers, row after row).
    pub fn point_responses(&self, i: usize) -> &[f64] {
        &self.minv_jt[3 * i * self.nv..3 * (i + 1) * self.nv]
    }

    /// W[r][s] = d_rᵀ·J_r·M⁻¹·J_sᵀ·d_s of the latest [`World::point_frame_jacobians`].
    pub fn mobility(&self, r: usize, s: usize) -> f64 {
        dot_slices(self.jacobian(r), self.response(s))
    }
}

/// Σ a_k·b_k.
pub(crate) fn dot_slices(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// One row of a point's Jacobian along `dir`: dᵀ·J, J the point's 3 × nv translational Jacobian
/// (row after row, as `mj_jac` writes it); `row` holds nv numbers.
fn directional_row(jac: &[f64], dir: [f64; 3], row: &mut [f64]) {
    let nv = row.len();
    for (k, x) in row.iter_mut().enumerate() {
        *x = dir[0] * jac[k] + dir[1] * jac[nv + k] + dir[2] * jac[2 * nv + k];
    }
}

/// A saved engine state of a [`World`] ([`World::save_state`]).
#[derive(Clone)]
pub struct WorldState {
    data: MjData<Box<MjModel>>,
    sensor_time_secs: f64,
}

impl WorldState {
    /// The engine state (`qpos`, `qvel`, `act`, `time`, …), read-only.
    pub fn data(&self) -> &MjData<Box<MjModel>> {
        &self.data
    }
}

/// A compiled world: model, engine state and the index of the robot in it.
///
/// The engine state owns its model (`Box`), so the few model parameters that MuJoCo allows to
/// change during a run (contact-pair friction, for directional friction) can be changed; use
/// [`World::model`] to read it.
pub struct World {
    /// The engine state (with its model): private, read through the accessors.
    data: MjData<Box<MjModel>>,
    /// Resolved ids and addresses.
    pub index: Index,
    /// The MJCF the world was compiled from.
    pub mjcf: String,
    /// Files written beside `mjcf` into the run folder (name, contents): the scene split into
    /// `scene.xml`, `terrain.xml`, `robot.xml` (see `model::SceneFiles`), and a user's robot.
    pub included_files: Vec<(String, String)>,
    /// Files copied into the run folder (terrain sources, a third-party terrain and its assets).
    pub copied_files: Vec<model::features::FileCopy>,
    /// Initial joint angles (rad) the world starts from.
    pub initial_joint_angles_rad: Vec<f64>,
    /// Simulated time that `sensordata` describes (the last complete model evaluation).
    sensor_time_secs: f64,
    /// Contact-pair friction as compiled, restored by [`World::reset`] (the ground model
    /// changes it during a run).
    initial_pair_friction: Vec<[f64; 5]>,
    /// How far below its keyframe the snake starts (m): the depth at which the floor's contact
    /// law carries its weight when it starts at rest lying on level ground (see
    /// [`crate::sim::Ground::static_start_sink_m`]); applied by [`World::reset`].
    start_sink_m: f64,
}

impl World {
    /// Generates the snake world that `config` describes and compiles it.
    pub fn from_config(config: &Config) -> Result<Self, SimError> {
        let generated = model::generate(config)?;
        Self::from_generated(config, generated)
    }

    /// Compiles a generated model.
    pub fn from_generated(config: &Config, generated: GeneratedModel) -> Result<Self, SimError> {
        let model = if generated.files.model_needs_files {
            // A third-party terrain is included: compile from a folder that holds every file.
            // Removed when `scratch` is dropped, whichever way this block ends.
            let scratch = scratch_dir("model")?;
            let path =
                write_model_folder(scratch.path(), &generated.xml, &generated.files.texts, &generated.files.copies)?;
            // MuJoCo's message names the copies in the scratch folder: name the user's files.
            let renames: Vec<(String, String)> = generated
                .files
                .copies
                .iter()
                .map(|c| (scratch.path().join(&c.dest).display().to_string(), c.source.display().to_string()))
                .collect();
            let what =
                format!("the model with the third-party terrain {}", user_terrain_source(&generated.files.copies));
            compile::compile(compile::Mjcf::File(&path), &what, &renames)?
        } else {
            compile::compile(compile::Mjcf::Text(&generated.xml), "the generated model", &[])?
        };
        let index = Index::for_snake(&model, config.snake.n_links)?;
        let initial_pair_friction = model.pair_friction().to_vec();
        let mut world = Self {
            data: MjData::new(Box::new(model)),
            index,
            mjcf: generated.xml,
            included_files: generated.files.texts,
            copied_files: generated.files.copies,
            initial_joint_angles_rad: generated.initial_joint_angles_rad,
            sensor_time_secs: 0.0,
            initial_pair_friction,
            start_sink_m: 0.0,
        };
        world.reset()?;
        world.check_start_clear(config, "the snake")?;
        Ok(world)
    }

    /// Fails when the robot starts inside the floor, an obstacle or a terrain feature deeper than
    /// [`START_PENETRATION_TOLERANCE_M`]: MuJoCo's collision detection at the starting state
    /// (the contacts of the last forward pass) is the check, so it sees slopes, heightfields,
    /// meshes and third-party terrain exactly as the run will. A snake started 72 mm inside a box
    /// would otherwise be thrown out of it with kilonewtons in the first steps.
    pub fn check_start_clear(&mut self, config: &Config, what: &str) -> Result<(), SimError> {
        let Some((depth, link, other)) = self.start_penetration() else { return Ok(()) };
        // The snake: how far up it must start to clear everything (found by moving it up, since a
        // heightfield's or a slope's contact depth is not the height to raise by).
        let raise_m = if what == "the snake" { self.raise_to_clear_m(depth) } else { None };
        let names = &self.index.geom_names;
        let other_name = names.get(other).map_or("?", String::as_str);
        let link_name = names.get(link).map_or("?", String::as_str);
        let source = match other_name {
            model::names::FLOOR => "the floor (z = 0)",
            model::names::TERRAIN_SLOPE => "the slope (terrain.slope.*)",
            model::names::TERRAIN_HEIGHTFIELD => "the heightfield (terrain.heightfield.*)",
            model::names::TERRAIN_MESH => "the mesh terrain (terrain.mesh_terrain.*)",
            n if n.starts_with("obstacle_") => {
                "an obstacle (terrain.kind, terrain.pegboard, terrain.walls, terrain.channel or terrain.mesh_obstacles)"
            }
            _ => "a geom of the scene (terrain.include_mjcf or the robot file)",
        };
        let (key, value, fix) = if what == "the snake" {
            (
                "snake.head_position_m",
                format!("{:?}", config.snake.head_position_m),
                match raise_m {
                    Some(raise_m) => format!(
                        "raise the snake (snake.head_position_m[2] up by {raise_m} m clears everything at the start; \
                         on a slope, turn it with snake.head_rotation_deg), or move {source} away from the starting \
                         pose"
                    ),
                    None => format!(
                        "raise the snake (snake.head_position_m[2] up by more than {depth:.4} m; on a slope, turn it \
                         with snake.head_rotation_deg), or move {source} away from the starting pose"
                    ),
                },
            )
        } else {
            (
                "robot.position_m",
                format!("{:?}", config.robot.position_m),
                format!(
                    "move the robot (robot.position_m; robot.place_on_floor = true only clears the floor), or move \
                     {source} away from its starting pose"
                ),
            )
        };
        Err(SimError::Config(crate::config::ConfigError::InvalidValue {
            key: key.into(),
            value,
            allowed: format!(
                "{what} would start {:.1} mm deep inside {source}: geom `{link_name}` overlaps `{other_name}` at the \
                 starting pose (more than the {} mm allowed), which throws it out with large contact forces in the \
                 first steps; {fix}",
                depth * 1e3,
                START_PENETRATION_TOLERANCE_M * 1e3
            ),
        }))
    }

    /// The deepest contact of a link with anything but another link at the current state (from
    /// the last forward pass), when deeper than [`START_PENETRATION_TOLERANCE_M`]: (depth (m),
    /// link geom, other geom).
    fn start_penetration(&self) -> Option<(f64, usize, usize)> {
        use crate::state::GeomClass;
        let class = |g: i32| usize::try_from(g).ok().and_then(|g| self.index.geom_class.get(g).copied());
        let mut worst: Option<(f64, usize, usize)> = None;
        for contact in self.data.contact() {
            let pair = match (class(contact.geom[0]), class(contact.geom[1])) {
                (Some(GeomClass::Link(_)), Some(GeomClass::Link(_))) => None,
                (Some(GeomClass::Link(_)), Some(_)) => Some((contact.geom[0], contact.geom[1])),
                (Some(_), Some(GeomClass::Link(_))) => Some((contact.geom[1], contact.geom[0])),
                _ => None,
            };
            if let Some((link, other)) = pair {
                let depth = -contact.dist;
                if depth > START_PENETRATION_TOLERANCE_M && worst.is_none_or(|w| depth > w.0) {
                    worst = Some((depth, link as usize, other as usize));
                }
            }
        }
        worst
    }

    /// How far the snake must start higher (m, rounded up to the millimetre) so that no link
    /// starts inside anything: the whole snake is moved up through its free joint and MuJoCo's
    /// collision detection checks each height (doubling from `depth_m`, then bisection). The
    /// state is restored afterwards. `None` without a free joint or when 100 m do not clear it.
    fn raise_to_clear_m(&mut self, depth_m: f64) -> Option<f64> {
        let z = self.index.head_free_qpos_adr? + 2;
        let z0 = self.data.qpos()[z];
        let clear_at = |w: &mut Self, raise_m: f64| {
            w.data.qpos_mut()[z] = z0 + raise_m;
            w.forward();
            w.start_penetration().is_none()
        };
        let mut hi = depth_m.max(1e-3);
        while !clear_at(self, hi) {
            hi *= 2.0;
            if hi > 100.0 {
                clear_at(self, 0.0);
                return None;
            }
        }
        let mut lo = 0.0;
        while hi - lo > 1e-5 {
            let mid = 0.5 * (lo + hi);
            if clear_at(self, mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let rounded = (hi * 1e3).ceil() / 1e3;
        let raise_m = if clear_at(self, rounded) { rounded } else { hi };
        clear_at(self, 0.0);
        Some(raise_m)
    }

    /// A user's robot (MJCF or URDF, as MuJoCo's loader reads them) placed in the terrain that
    /// `config` describes. The robot file is included unchanged into a scene file; a URDF is
    /// first converted to MJCF by MuJoCo.
    pub fn from_robot_file(config: &Config, robot: &Path, scratch_dir: &Path) -> Result<Self, SimError> {
        let file = robot.display().to_string();
        let robot_err = |message: String| SimError::RobotFile { file: file.clone(), message };
        // A regular file (after following symbolic links) of at most MAX_MJCF_BYTES: not a
        // device or FIFO that MuJoCo's parser would read without end.
        let bytes = model::files::read_regular_file(robot, model::files::MAX_MJCF_BYTES)
            .map_err(|e| robot_err(e.to_string()))?;
        // One pass before MuJoCo reads it: NaN or infinities, which MuJoCo would take as they are
        // (a NaN joint limit runs to the end), a chain longer than MuJoCo can load, and more links
        // than MuJoCo sets up in seconds.
        let scan = model::files::scan_robot_file(&bytes);
        drop(bytes);
        if let Some(number) = scan.non_finite {
            return Err(robot_err(number.to_string()));
        }
        let cap = model::files::MAX_ROBOT_CHAIN_LINKS;
        if scan.longest_chain_links > cap {
            return Err(robot_err(format!(
                "its longest chain has {} links (to `{}`); a robot may have at most {cap} links on one chain \
                 (MuJoCo reads a robot as nested bodies and stops at 500 nested elements, and a chain's step \
                 cost grows with about the cube of its length)",
                scan.longest_chain_links,
                crate::config::shorten(&scan.deepest_link)
            )));
        }
        let cap = model::files::MAX_ROBOT_LINKS;
        if scan.links > cap {
            return Err(robot_err(format!(
                "it has {} links; a robot may have at most {cap} links in all (MuJoCo's set-up time grows with \
                 about the square of the number of links)",
                scan.links
            )));
        }
        let robot_model = MjModel::from_xml(robot).map_err(|e| {
            let message = compile::full_load_error(compile::Mjcf::File(robot)).unwrap_or_else(|| e.to_string());
            robot_err(format!("MuJoCo cannot load the robot ({message})"))
        })?;
        drop(robot_model);
        if config.initial_state != crate::config::Config::default().initial_state {
            return Err(SimError::Config(crate::config::ConfigError::InvalidValue {
                key: "initial_state".into(),
                value: "(set)".into(),
                allowed: "[initial_state] sets the generated snake's starting joint angles and velocity; with \
                          --robot leave it at its defaults and give the robot's start in [robot] (position_m, \
                          rotation_deg, floating_base, place_on_floor) and its joints' reference angles in its file"
                    .into(),
            }));
        }
        // MJCF of the robot (URDF converted), placed as [robot] says, with absolute asset paths
        // kept by MuJoCo.
        let robot_text = robot::prepared_mjcf(config, robot, scratch_dir).map_err(robot_err)?;
        let scene = model::scene_with_robot("robot.xml", config)?;
        let mut texts = vec![("robot.xml".to_string(), robot_text)];
        texts.extend(scene.files.texts.iter().cloned());
        let scene_path = write_model_folder(scratch_dir, &scene.xml, &texts, &scene.files.copies)
            .map_err(|e| robot_err(e.to_string()))?;
        let model = MjModel::from_xml(&scene_path)
            .map_err(|e| robot_err(format!("MuJoCo cannot load the robot inside the terrain ({e})")))?;
        let index = Index::for_robot(&model, config.control.method).map_err(robot_err)?;
        let link_names: Vec<String> = index.links.iter().map(|l| l.name.clone()).collect();
        external::check_robot_links(config, &link_names, &file)?;
        safety::check_robot_actuators(config, &index).map_err(robot_err)?;
        let initial_pair_friction = model.pair_friction().to_vec();
        let mut world = Self {
            data: MjData::new(Box::new(model)),
            mjcf: scene.xml,
            included_files: texts,
            copied_files: scene.files.copies,
            initial_joint_angles_rad: vec![0.0; index.joints.len()],
            index,
            sensor_time_secs: 0.0,
            initial_pair_friction,
            start_sink_m: 0.0,
        };
        world.reset()?;
        world.check_start_clear(config, "the robot")?;
        Ok(world)
    }

    /// Resets the state to the model's "initial" keyframe (or its default pose), the contact-pair
    /// friction to the compiled one, and computes all derived quantities.
    pub fn reset(&mut self) -> Result<(), SimError> {
        for pair in 0..self.initial_pair_friction.len() {
            let friction = self.initial_pair_friction[pair];
            self.set_pair_friction(pair, friction);
        }
        match self.model().name_to_id(MjtObjBase::mjOBJ_KEY, model::names::INITIAL_KEYFRAME) {
            Some(key) => {
                self.data.reset_keyframe(key).map_err(|e| SimError::Model(format!("cannot reset to keyframe: {e}")))?
            }
            None => self.data.reset(),
        }
        if let Some(adr) = self.index.head_free_qpos_adr.filter(|_| self.start_sink_m > 0.0) {
            self.data.qpos_mut()[adr + 2] -= self.start_sink_m;
        }
        self.forward();
        Ok(())
    }

    /// Starts the snake `sink_m` below its keyframe, now (the world at its keyframe state) and
    /// after every [`World::reset`].
    pub(crate) fn set_start_sink_m(&mut self, sink_m: f64) {
        if let Some(adr) = self.index.head_free_qpos_adr {
            self.data.qpos_mut()[adr + 2] -= sink_m - self.start_sink_m;
            self.start_sink_m = sink_m;
            self.forward();
        }
    }

    /// How far below its keyframe the snake starts (m; 0 unless it starts resting on level
    /// ground under SimSerpent's contact law).
    pub fn start_sink_m(&self) -> f64 {
        self.start_sink_m
    }

    /// MuJoCo's forward pass at the current state and controls.
    pub fn forward(&mut self) {
        self.data.forward();
        self.sensor_time_secs = self.data.time();
    }

    /// [`World::forward`] from the actuation stage on, with the sensors: for a state whose
    /// position and velocity stages a full forward pass computed already, with nothing but the
    /// controls and applied forces changed since. Bit for bit [`World::forward`]'s result.
    pub(crate) fn forward_from_actuation(&mut self) {
        self.data.forward_skip(mujoco_rs::prelude::MjtStage::mjSTAGE_VEL, false);
        self.sensor_time_secs = self.data.time();
    }

    /// How forces at points of the bodies move those points, at the latest forward pass: for
    /// rows r = (body, point, unit direction d), `w` gets the n × n matrix (row-major)
    /// W[r][s] = d_rᵀ·J_r·M⁻¹·J_sᵀ·d_s — the acceleration along d_r that a unit force along d_s
    /// at point s causes, through the whole articulated body — and `acc` the acceleration of
    /// each point along its direction in that forward pass, d_rᵀ·J_r·q̈ (the velocity-product
    /// term J̇·q̇ left out). Uses the mass matrix factorised by the forward pass; the buffers
    /// keep their capacity, so a warmed-up caller does not allocate.
    pub(crate) fn point_mobility(&mut self, rows: &[(usize, [f64; 3], [f64; 3])], buf: &mut MobilityBuffers) {
        let nv = self.data.model().ffi().nv as usize;
        let n = rows.len();
        buf.jac.resize(3 * nv, 0.0);
        buf.jt.clear();
        buf.jt.resize(n * nv, 0.0);
        buf.minv_jt.clear();
        buf.minv_jt.resize(n * nv, 0.0);
        buf.w.clear();
        buf.w.resize(n * n, 0.0);
        buf.acc.clear();
        buf.acc.resize(n, 0.0);
        if n == 0 || nv == 0 {
            return;
        }
        for (r, (body, point, dir)) in rows.iter().enumerate() {
            self.point_jacobian(*body, point, &mut buf.jac);
            directional_row(&buf.jac, *dir, &mut buf.jt[r * nv..(r + 1) * nv]);
        }
        self.solve_mass_matrix(&mut buf.minv_jt, &buf.jt, n);
        let qacc = self.data.qacc();
        for r in 0..n {
            let jr = &buf.jt[r * nv..(r + 1) * nv];
            buf.acc[r] = dot_slices(jr, qacc);
            for s in 0..n {
                buf.w[r * n + s] = dot_slices(jr, &buf.minv_jt[s * nv..(s + 1) * nv]);
            }
        }
    }

    /// The translational Jacobian of `point` (world frame) on `body` into `jac` (3 × nv, row
    /// after row), from the kinematics of the latest forward pass.
    fn point_jacobian(&self, body: usize, point: &[f64; 3], jac: &mut [f64]) {
        let nv = self.data.model().ffi().nv as usize;
        assert!(jac.len() >= 3 * nv, "a point's Jacobian needs 3·nv numbers");
        // SAFETY: `jac` holds 3·nv numbers (checked), as mj_jac writes for one point; model and
        // data belong together and the body id is one of the model's (a link's body).
        #[allow(unsafe_code)]
        unsafe {
            mujoco_rs::mujoco_c::mj_jac(
                self.data.model().ffi(),
                self.data.ffi(),
                jac.as_mut_ptr(),
                std::ptr::null_mut(),
                point,
                body as i32,
            );
        }
    }

    /// `out` = M⁻¹·`rhs` for `count` vectors of nv numbers each, with the factorisation of the
    /// mass matrix (qLD) the latest forward pass left in `data`.
    fn solve_mass_matrix(&mut self, out: &mut [f64], rhs: &[f64], count: usize) {
        let nv = self.data.model().ffi().nv as usize;
        assert!(out.len() >= count * nv && rhs.len() >= count * nv, "M⁻¹ needs count·nv numbers");
        // SAFETY: `out` and `rhs` hold `count` vectors of nv numbers each (checked), as mj_solveM
        // reads and writes; it only reads the factorisation in `data`.
        #[allow(unsafe_code)]
        unsafe {
            let m: *const mujoco_rs::mujoco_c::mjModel = self.data.model().ffi();
            mujoco_rs::mujoco_c::mj_solveM(m, self.data.ffi_mut(), out.as_mut_ptr(), rhs.as_ptr(), count as i32);
        }
    }

    /// Like [`World::point_mobility`] for contact points with a frame of three directions each
    /// (`points`: body, point, directions), without the dense W: one `mj_jac` per point gives
    /// its three rows d·J (row 3·i + k for direction k of point i), one `mj_solveM` their
    /// M⁻¹·Jᵀ·d, and `acc` each row's acceleration d·J·q̈ in the latest forward pass. The
    /// buffers' [`MobilityBuffers::jacobian`], [`MobilityBuffers::response`] and
    /// [`MobilityBuffers::mobility`] read them; no allocation once warmed up.
    pub(crate) fn point_frame_jacobians(&mut self, points: &[PointFrame], buf: &mut MobilityBuffers) {
        let nv = self.data.model().ffi().nv as usize;
        let n = 3 * points.len();
        buf.nv = nv;
        // Every entry below is written before it is read: resized, not cleared.
        buf.jac.resize(3 * nv, 0.0);
        buf.jt.resize(n * nv, 0.0);
        buf.minv_jt.resize(n * nv, 0.0);
        buf.acc.resize(n, 0.0);
        if n == 0 || nv == 0 {
            return;
        }
        for (i, (body, point, dirs)) in points.iter().enumerate() {
            self.point_jacobian(*body, point, &mut buf.jac);
            for (k, dir) in dirs.iter().enumerate() {
                directional_row(&buf.jac, *dir, &mut buf.jt[(3 * i + k) * nv..(3 * i + k + 1) * nv]);
            }
        }
        if n <= nv {
            self.solve_mass_matrix(&mut buf.minv_jt, &buf.jt, n);
        } else {
            // More rows than degrees of freedom: M⁻¹ itself (nv solves), then M⁻¹·Jᵀ·d per row
            // (M⁻¹ is symmetric: row r's response is M⁻¹ times its Jacobian).
            if buf.identity.len() != nv * nv {
                buf.identity.clear();
                buf.identity.resize(nv * nv, 0.0);
                for k in 0..nv {
                    buf.identity[k * nv + k] = 1.0;
                }
            }
            buf.minv.resize(nv * nv, 0.0);
            self.solve_mass_matrix(&mut buf.minv, &buf.identity, nv);
            for (jr, out) in buf.jt.chunks_exact(nv).zip(buf.minv_jt.chunks_exact_mut(nv)) {
                out.fill(0.0);
                for (mk, &j) in buf.minv.chunks_exact(nv).zip(jr) {
                    if j != 0.0 {
                        for (o, m) in out.iter_mut().zip(mk) {
                            *o += m * j;
                        }
                    }
                }
            }
        }
        let qacc = self.data.qacc();
        for r in 0..n {
            buf.acc[r] = dot_slices(&buf.jt[r * nv..(r + 1) * nv], qacc);
        }
    }

    /// One `mj_step`. Afterwards `sensordata` describes the state at the start of the step
    /// (MuJoCo evaluates sensors in the step's first forward pass, also with RK4).
    pub fn step(&mut self) {
        self.sensor_time_secs = self.data.time();
        self.data.step();
    }

    /// The rest of one `mj_step` after [`World::forward`] ran at the current state and controls
    /// (and nothing changed since): MuJoCo's acceleration check, the forward/inverse comparison
    /// when enabled, and the configured integrator (`mj_Euler`, `mj_RungeKutta`, `mj_implicit`)
    /// — what `mj_step` does after its own forward pass, which would repeat the one already
    /// done. The result is bit for bit that of `mj_step` (`mj_forward` is a pure function of
    /// the state, controls and applied forces; tests/it `step_loop` compares).
    ///
    /// `mj_step` checks positions and velocities *before* its forward pass and resets a bad
    /// state (NaN or larger than 1e10); when that would happen, this runs `mj_step` itself, so
    /// a diverging run ends exactly as before.
    pub fn step_after_forward(&mut self) {
        /// MuJoCo's `mjMAXVAL`: `mju_isBad` is NaN or a magnitude above it.
        const MJ_MAX_VAL: f64 = 1e10;
        let bad = |x: &f64| x.is_nan() || x.abs() > MJ_MAX_VAL;
        if self.data.qpos().iter().any(bad) || self.data.qvel().iter().any(bad) {
            self.step();
            return;
        }
        let opt = self.data.model().opt();
        let (integrator, enable_flags) = (opt.integrator, opt.enableflags);
        let integrate: fn(&mut MjData<Box<MjModel>>) = match integrator {
            i if i == MjtIntegrator::mjINT_EULER as i32 => MjData::euler,
            i if i == MjtIntegrator::mjINT_RK4 as i32 => |d| d.runge_kutta(4),
            i if i == MjtIntegrator::mjINT_IMPLICIT as i32 || i == MjtIntegrator::mjINT_IMPLICITFAST as i32 => {
                MjData::implicit
            }
            // An integrator this code does not know: MuJoCo's own step (one forward pass more).
            _ => {
                self.step();
                return;
            }
        };
        self.sensor_time_secs = self.data.time();
        self.data.check_acc();
        if enable_flags & (MjtEnableBit::mjENBL_FWDINV as i32) != 0 {
            self.data.compare_fwd_inv();
        }
        integrate(&mut self.data);
    }

    /// The compiled model.
    pub fn model(&self) -> &MjModel {
        self.data.model()
    }

    /// The engine state, read-only (for rendering and for analyses that need MuJoCo's own
    /// arrays; the step loop is the only writer).
    pub fn data(&self) -> &MjData<Box<MjModel>> {
        &self.data
    }

    /// Simulated time (s).
    pub fn time_secs(&self) -> f64 {
        self.data.time()
    }

    /// The physics timestep (s).
    pub fn timestep_secs(&self) -> f64 {
        self.data.model().opt().timestep
    }

    /// Joint positions, writable: for setting an initial condition before a run (call
    /// [`World::forward`] afterwards).
    pub fn qpos_mut(&mut self) -> &mut [f64] {
        self.data.qpos_mut()
    }

    /// Joint velocities, writable: for setting an initial condition before a run (call
    /// [`World::forward`] afterwards).
    pub fn qvel_mut(&mut self) -> &mut [f64] {
        self.data.qvel_mut()
    }

    /// Applied generalized forces (MuJoCo's `qfrc_applied`), writable: an external load held
    /// until changed (the step loop writes it only with `[[physics.external_forces]]`). For the head's free joint, entries
    /// 0–2 are a force (N, world frame) at the head link's centre of mass.
    pub fn qfrc_applied_mut(&mut self) -> &mut [f64] {
        self.data.qfrc_applied_mut()
    }

    /// The actuator controls, writable (the bare-engine benchmark writes them directly).
    pub fn ctrl_mut(&mut self) -> &mut [f64] {
        self.data.ctrl_mut()
    }

    /// Linear momentum (kg·m/s) and angular momentum about the centre of mass (kg·m²/s) of
    /// the subtree of `body` at the current state (computes MuJoCo's subtree velocities).
    pub fn subtree_momentum(&mut self, body: usize) -> ([f64; 3], [f64; 3]) {
        self.data.subtree_vel();
        let mass = self.data.model().body_subtreemass()[body];
        let v = self.data.subtree_linvel()[body];
        (v.map(|x| x * mass), self.data.subtree_angmom()[body])
    }

    /// Centre of mass of the subtree of `body` (m), of the last kinematics computed.
    pub fn subtree_com_m(&self, body: usize) -> [f64; 3] {
        self.data.subtree_com()[body]
    }

    /// Mass-weighted centre of the robot's links (m), from the last kinematics computed.
    pub fn centre_of_mass_m(&self) -> [f64; 3] {
        let xipos = self.data.xipos();
        state::centre_of_mass_m(self.index.links.iter().map(|l| (l.mass_kg, xipos[l.body])))
    }

    /// The way the head faces in the xy-plane (its link's +x axis), from the last kinematics.
    pub fn head_heading_xy(&self) -> [f64; 2] {
        self.index.links.first().map_or([1.0, 0.0], |head| state::heading_xy(self.data.xquat()[head.body]))
    }

    /// Σ over joints of |τ·q̇| (W): MuJoCo's joint-space actuator torque of the last evaluation
    /// times the current joint velocity.
    pub fn actuator_power_w(&self) -> f64 {
        let (qfrc, qvel) = (self.data.qfrc_actuator(), self.data.qvel());
        state::actuator_power_w(self.index.joints.iter().map(|j| (qfrc[j.dof_adr], qvel[j.dof_adr])))
    }

    /// Largest contact normal force of the last evaluation's contacts (N).
    pub fn peak_contact_force_n(&self) -> f64 {
        let d = &self.data;
        state::peak_contact_force_n((0..d.contact().len()).map(|c| d.contact_force(c)[0]))
    }

    /// Sets the collision bits and margin of geom `geom` (MuJoCo's `contype`, `conaffinity`,
    /// `margin`): SimSerpent's contact law switches the ground geoms off for MuJoCo's step.
    pub(crate) fn set_geom_collision(&mut self, geom: usize, contype: i32, conaffinity: i32, margin: f64) {
        // SAFETY: only the values of an existing geom's collision bits change; no size, index
        // or address of the model changes, which is what `model_mut` requires us to keep.
        #[allow(unsafe_code)]
        let model = unsafe { self.data.model_mut() };
        if let Some(t) = model.geom_contype_mut().get_mut(geom) {
            *t = contype;
        }
        if let Some(a) = model.geom_conaffinity_mut().get_mut(geom) {
            *a = conaffinity;
        }
        if let Some(m) = model.geom_margin_mut().get_mut(geom) {
            *m = margin;
        }
    }

    /// Sets the friction of contact pair `pair` (tangent 1, tangent 2, torsional, rolling 1, 2).
    /// MuJoCo reads pair friction afresh at every collision detection, so this takes effect at
    /// the next step. Returns false if there is no such pair.
    pub fn set_pair_friction(&mut self, pair: usize, friction: [f64; 5]) -> bool {
        // SAFETY: only the values of an existing pair's friction change; no size, index or
        // address of the model changes, which is what `model_mut` requires us to keep.
        #[allow(unsafe_code)]
        let model = unsafe { self.data.model_mut() };
        match model.pair_friction_mut().get_mut(pair) {
            Some(slot) => {
                *slot = friction;
                true
            }
            None => false,
        }
    }

    /// A copy of the whole engine state (MuJoCo's `mjData`, so also the contacts, sensor
    /// values and warm start the next step reads, and the contact-pair friction): restoring it
    /// with [`World::restore_state`] continues bit for bit as from here.
    pub fn save_state(&self) -> WorldState {
        WorldState { data: self.data.clone(), sensor_time_secs: self.sensor_time_secs }
    }

    /// Goes back to a state saved from this world by [`World::save_state`].
    ///
    /// # Errors
    /// The state was saved from a world of another model.
    pub fn restore_state(&mut self, state: &WorldState) -> Result<(), SimError> {
        state
            .data
            .copy_to(&mut self.data)
            .map_err(|e| SimError::Model(format!("the state belongs to another model: {e}")))?;
        for (pair, friction) in state.data.model().pair_friction().iter().enumerate() {
            self.set_pair_friction(pair, *friction);
        }
        self.sensor_time_secs = state.sensor_time_secs;
        Ok(())
    }

    /// Number of links and joints.
    pub fn n_links(&self) -> usize {
        self.index.links.len()
    }
    /// Number of 1-DOF joints.
    pub fn n_joints(&self) -> usize {
        self.index.joints.len()
    }

    /// The 1-DOF joints that no actuator drives (a URDF robot's, without
    /// `robot.position_servos`): passive, whatever the controller commands.
    pub fn passive_joints(&self) -> Vec<&str> {
        self.index.joints.iter().filter(|j| j.actuators.iter().all(Option::is_none)).map(|j| j.name.as_str()).collect()
    }

    /// Writes a command into MuJoCo's `ctrl`.
    pub fn apply_command(&mut self, cmd: &Command) {
        let ctrl = self.data.ctrl_mut();
        for (j, joint) in self.index.joints.iter().enumerate() {
            for (slot, kind) in joint.actuators.iter().zip(ControlMethod::ALL) {
                if let Some(a) = *slot {
                    ctrl[a] = cmd.block(kind)[j];
                }
            }
        }
    }

    /// Fills the exact (noise-free) observation from the current state: joint angles and
    /// velocities and the head's pose and velocity of the state itself, sensors of the last
    /// complete evaluation (`Observation::sensor_time_secs`).
    pub fn observe_true(&self, obs: &mut Observation) {
        let d = &self.data;
        let qpos = d.qpos();
        let qvel = d.qvel();
        let sensordata = d.sensordata();
        let qfrc_actuator = d.qfrc_actuator();
        obs.time_secs = d.time();
        for (j, joint) in self.index.joints.iter().enumerate() {
            obs.joint_angle_rad[j] = qpos[joint.qpos_adr];
            obs.joint_velocity_rad_per_s[j] = qvel[joint.dof_adr];
            obs.actuator_torque_nm[j] = qfrc_actuator[joint.dof_adr];
            read3(sensordata, joint.force_adr, &mut obs.joint_force_n[j]);
            read3(sensordata, joint.torque_adr, &mut obs.joint_torque_nm[j]);
        }
        for (i, link) in self.index.links.iter().enumerate() {
            read3(sensordata, link.accelerometer_adr, &mut obs.imu_accel_m_per_s2[i]);
            read3(sensordata, link.gyro_adr, &mut obs.imu_gyro_rad_per_s[i]);
            if let Some(a) = link.framequat_adr {
                obs.imu_quat_wxyz[i].copy_from_slice(&sensordata[a..a + 4]);
            }
        }
        if let Some(free) = self.index.head_free {
            // From the state itself: after an RK4 step the last kinematics are those of the
            // step's final Runge–Kutta stage, not of the state reached (joint angles come from
            // qpos; a head pose from `xquat` would not fit them).
            let (p, v) = (&qpos[free.qpos_adr..free.qpos_adr + 7], &qvel[free.dof_adr..free.dof_adr + 6]);
            obs.head_position_m = [p[0], p[1], p[2]];
            obs.head_quat = normalized_as_mujoco([p[3], p[4], p[5], p[6]]);
            // The centre of mass's velocity: the origin's plus ω × (R·c), ω = R·ω_body.
            let rot = crate::estimation::quat_to_matrix(obs.head_quat);
            let omega = crate::estimation::rotate(&rot, [v[3], v[4], v[5]]);
            let r = crate::estimation::rotate(&rot, free.com_local_m);
            obs.head_velocity_m_per_s = [
                v[0] + omega[1] * r[2] - omega[2] * r[1],
                v[1] + omega[2] * r[0] - omega[0] * r[2],
                v[2] + omega[0] * r[1] - omega[1] * r[0],
            ];
        } else if let Some(head) = self.index.links.first() {
            obs.head_position_m = d.xpos()[head.body];
            obs.head_quat = d.xquat()[head.body];
            let v = d.object_velocity(MjtObjBase::mjOBJ_BODY, head.body, false);
            obs.head_velocity_m_per_s = [v[3], v[4], v[5]];
        }
        // Sensor values come from the last complete evaluation: the start of the previous step,
        // unless a forward pass ran at this state (see ARCHITECTURE.md).
        obs.sensor_time_secs = self.sensor_time_secs;
    }

    /// The simulator's link poses and velocities (centre of mass, world frame) of the current
    /// kinematics, for an estimator's comparison with the true orientations. Does not allocate.
    pub fn read_link_poses(&self, poses: &mut crate::estimation::LinkPoses) {
        let d = &self.data;
        let (xipos, xquat, xpos) = (d.xipos(), d.xquat(), d.xpos());
        for (i, link) in self.index.links.iter().enumerate().take(poses.quat.len()) {
            poses.quat[i] = xquat[link.body];
            poses.com_m[i] = xipos[link.body];
            poses.origin_m[i] = xpos[link.body];
            let v = d.object_velocity(MjtObjBase::mjOBJ_BODY, link.body, false);
            poses.angular_velocity_rad_per_s[i] = [v[0], v[1], v[2]];
            poses.com_velocity_m_per_s[i] = [v[3], v[4], v[5]];
        }
    }

    /// Checks the state for NaN or infinite values and MuJoCo's own instability warnings (bad
    /// qacc, qpos, qvel, and bad ctrl: a NaN or huge command from the controller).
    /// `time_secs` is the simulated time the step reached (MuJoCo's own clock restarts when it
    /// resets a diverged state).
    pub fn check_finite(&self, step: u64, time_secs: f64) -> Result<(), SimError> {
        let d = &self.data;
        let diverged = |what: String| SimError::Diverged { time_secs, step, what };
        if let Some(i) = d.qpos().iter().position(|x| !x.is_finite()) {
            return Err(diverged(format!("qpos[{i}] is not finite")));
        }
        if let Some(i) = d.qvel().iter().position(|x| !x.is_finite()) {
            return Err(diverged(format!("qvel[{i}] is not finite")));
        }
        let warnings = d.warning();
        for (kind, label) in [
            (MjtWarning::mjWARN_BADQACC, "MuJoCo reset the state: bad acceleration (mjWARN_BADQACC)"),
            (MjtWarning::mjWARN_BADQPOS, "MuJoCo reset the state: bad position (mjWARN_BADQPOS)"),
            (MjtWarning::mjWARN_BADQVEL, "MuJoCo reset the state: bad velocity (mjWARN_BADQVEL)"),
            (
                MjtWarning::mjWARN_BADCTRL,
                "MuJoCo zeroed a bad control (mjWARN_BADCTRL): the controller's command is NaN, infinite or \
                 larger than 1e10",
            ),
        ] {
            if warnings[kind as usize].number > 0 {
                return Err(diverged(label.to_string()));
            }
        }
        Ok(())
    }

    /// Count of every MuJoCo warning kind raised so far, by name (for the manifest).
    pub fn warning_counts(&self) -> Vec<(String, i32)> {
        self.data
            .warning()
            .iter()
            .enumerate()
            .filter(|(_, w)| w.number > 0)
            .map(|(i, w)| (WARNING_NAMES.get(i).copied().unwrap_or("unknown").to_string(), w.number))
            .collect()
    }
}

/// Copies a 3-vector sensor reading at `adr` of `sensordata`, if the sensor exists.
pub(crate) fn read3(sensordata: &[f64], adr: Option<usize>, out: &mut [f64; 3]) {
    if let Some(a) = adr {
        out.copy_from_slice(&sensordata[a..a + 3]);
    }
}

/// MuJoCo's warning kinds, in `mjtWarning` order.
const WARNING_NAMES: [&str; 7] = [
    "inertia (mjWARN_INERTIA)",
    "contact buffer full (mjWARN_CONTACTFULL)",
    "constraint buffer full (mjWARN_CNSTRFULL)",
    "bad qpos (mjWARN_BADQPOS)",
    "bad qvel (mjWARN_BADQVEL)",
    "bad qacc (mjWARN_BADQACC)",
    "bad ctrl (mjWARN_BADCTRL)",
];

/// A quaternion normalised as MuJoCo's kinematics normalise a free joint's (`mju_normalize4`):
/// unchanged within 1e-15 of unit length, the identity when (nearly) zero.
fn normalized_as_mujoco(q: [f64; 4]) -> [f64; 4] {
    let norm = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if norm.is_nan() || norm < 1e-15 {
        [1.0, 0.0, 0.0, 0.0]
    } else if (norm - 1.0).abs() > 1e-15 {
        let inv = 1.0 / norm;
        q.map(|c| c * inv)
    } else {
        q
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    #[test]
    fn scratch_dir_is_private_random_and_removed_on_drop() {
        let a = super::scratch_dir("model").unwrap();
        let b = super::scratch_dir("model").unwrap();
        assert_ne!(a.path(), b.path(), "a fresh name every time");
        let name = a.path().file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.starts_with("simserpent-model-") && name.len() > "simserpent-model-".len() + 4, "{name}");
        let meta = a.path().symlink_metadata().unwrap();
        assert!(meta.is_dir() && !meta.file_type().is_symlink());
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(meta.permissions().mode() & 0o777, 0o700, "only the owner can enter it");
        }
        std::fs::write(a.path().join("model.xml"), "<mujoco/>").unwrap();
        let path = a.path().to_path_buf();
        drop(a);
        assert!(!path.exists(), "removed with its files when dropped");
    }
}

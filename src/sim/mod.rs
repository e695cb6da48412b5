//! The simulation: the only module that talks to MuJoCo.
//!
//! [`World`] holds the compiled model, the engine state and the resolved [`Index`].
//! [`Simulation`] runs the step loop: observe → controller → actuators → `mj_step`, and on
//! recorded steps a full `mj_forward` so that everything in a [`Snapshot`] describes one instant
//! (see ARCHITECTURE.md, "Order of work in a step").

mod ground;
mod index;
mod noise;
mod safety;
mod snapshot;

pub use ground::Ground;
pub use index::{GeomClass, Index, JointIndex, LinkIndex};
pub use noise::SensorNoise;
pub use safety::EnergyGuard;
pub use snapshot::{ContactRow, Snapshot};

use crate::config::{Config, ControlMethod};
use crate::control::{Command, Controller, Observation, TrajectoryController};
use crate::model::{self, GeneratedModel};
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
    #[error("model: {0}")]
    Model(String),
    /// A user's robot file could not be used.
    #[error("robot file {file}: {message}")]
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
}

/// A fresh scratch folder in the system's temp dir.
fn scratch_dir(what: &str) -> Result<std::path::PathBuf, SimError> {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let k = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("simserpent-{what}-{}-{k}", std::process::id()));
    std::fs::create_dir_all(&dir)
        .map_err(|e| SimError::Model(format!("cannot create scratch folder {} ({e})", dir.display())))?;
    Ok(dir)
}

/// The third-party terrain's source file among `copies`, for error messages.
fn user_terrain_source(copies: &[model::features::FileCopy]) -> String {
    copies
        .iter()
        .find(|c| c.dest == model::features::USER_TERRAIN_FILE)
        .map_or_else(String::new, |c| c.source.display().to_string())
}

/// Writes `model.xml`, the texts and the copies into `dir` (as in a run folder); returns the
/// path of `model.xml`.
pub fn write_model_folder(
    dir: &Path,
    model_xml: &str,
    texts: &[(String, String)],
    copies: &[model::features::FileCopy],
) -> Result<std::path::PathBuf, SimError> {
    let io = |path: &Path, e: std::io::Error| SimError::Model(format!("cannot write {} ({e})", path.display()));
    for c in copies {
        let dest = dir.join(&c.dest);
        if let Some(parent) = dest.parent() {
            std::fs::create_dir_all(parent).map_err(|e| io(parent, e))?;
        }
        std::fs::copy(&c.source, &dest)
            .map_err(|e| SimError::Model(format!("cannot copy {} to {} ({e})", c.source.display(), dest.display())))?;
    }
    for (name, text) in texts {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| io(&path, e))?;
    }
    let path = dir.join("model.xml");
    std::fs::write(&path, model_xml).map_err(|e| io(&path, e))?;
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

/// A compiled world: model, engine state and the index of the robot in it.
///
/// The engine state owns its model (`Box`), so the few model parameters that MuJoCo allows to
/// change during a run (contact-pair friction, for directional friction) can be changed; use
/// [`World::model`] to read it.
pub struct World {
    /// The engine state (with its model).
    pub data: MjData<Box<MjModel>>,
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
            let scratch = scratch_dir("model")?;
            let model = write_model_folder(&scratch, &generated.xml, &generated.files.texts, &generated.files.copies)
                .and_then(|path| {
                    MjModel::from_xml(&path).map_err(|e| {
                        SimError::Model(format!(
                            "MuJoCo rejected the model with the third-party terrain {}: {e}",
                            user_terrain_source(&generated.files.copies)
                        ))
                    })
                });
            let _ = std::fs::remove_dir_all(&scratch);
            model?
        } else {
            MjModel::from_xml_string(&generated.xml)
                .map_err(|e| SimError::Model(format!("MuJoCo rejected the generated model: {e}")))?
        };
        let index = Index::for_snake(&model, config.snake.n_links)?;
        let mut world = Self {
            data: MjData::new(Box::new(model)),
            index,
            mjcf: generated.xml,
            included_files: generated.files.texts,
            copied_files: generated.files.copies,
            initial_joint_angles_rad: generated.initial_joint_angles_rad,
            sensor_time_secs: 0.0,
        };
        world.reset()?;
        Ok(world)
    }

    /// A user's robot (MJCF or URDF, as MuJoCo's loader reads them) placed in the terrain that
    /// `config` describes. The robot file is included unchanged into a scene file; a URDF is
    /// first converted to MJCF by MuJoCo.
    pub fn from_robot_file(config: &Config, robot: &Path, scratch_dir: &Path) -> Result<Self, SimError> {
        let file = robot.display().to_string();
        let robot_err = |message: String| SimError::RobotFile { file: file.clone(), message };
        if !robot.is_file() {
            return Err(robot_err("robot file does not exist".into()));
        }
        let robot_model =
            MjModel::from_xml(robot).map_err(|e| robot_err(format!("MuJoCo cannot load the robot ({e})")))?;
        // Canonical MJCF of the robot (URDF converted), with absolute asset paths kept by MuJoCo.
        let robot_mjcf = scratch_dir.join("robot.xml");
        robot_model
            .save_last_xml(&robot_mjcf)
            .map_err(|e| robot_err(format!("cannot convert the robot to MJCF ({e})")))?;
        drop(robot_model);
        let robot_text = std::fs::read_to_string(&robot_mjcf)
            .map_err(|e| robot_err(format!("cannot read back {} ({e})", robot_mjcf.display())))?;
        let scene = model::scene_with_robot("robot.xml", config)?;
        let mut texts = vec![("robot.xml".to_string(), robot_text)];
        texts.extend(scene.files.texts.iter().cloned());
        let scene_path = write_model_folder(scratch_dir, &scene.xml, &texts, &scene.files.copies)
            .map_err(|e| robot_err(e.to_string()))?;
        let model = MjModel::from_xml(&scene_path)
            .map_err(|e| robot_err(format!("MuJoCo cannot load the robot inside the terrain ({e})")))?;
        let index = Index::for_robot(&model, config.control.method);
        safety::check_robot_actuators(config, &index).map_err(robot_err)?;
        let mut world = Self {
            data: MjData::new(Box::new(model)),
            mjcf: scene.xml,
            included_files: texts,
            copied_files: scene.files.copies,
            initial_joint_angles_rad: vec![0.0; index.joints.len()],
            index,
            sensor_time_secs: 0.0,
        };
        world.reset()?;
        Ok(world)
    }

    /// Resets the state to the model's "initial" keyframe (or its default pose) and computes
    /// all derived quantities.
    pub fn reset(&mut self) -> Result<(), SimError> {
        match self.model().name_to_id(MjtObjBase::mjOBJ_KEY, model::names::INITIAL_KEYFRAME) {
            Some(key) => {
                self.data.reset_keyframe(key).map_err(|e| SimError::Model(format!("cannot reset to keyframe: {e}")))?
            }
            None => self.data.reset(),
        }
        self.forward();
        Ok(())
    }

    /// MuJoCo's forward pass at the current state and controls.
    pub fn forward(&mut self) {
        self.data.forward();
        self.sensor_time_secs = self.data.time();
    }

    /// One `mj_step`. Afterwards `sensordata` describes the state at the start of the step
    /// (MuJoCo evaluates sensors in the step's first forward pass, also with RK4).
    pub fn step(&mut self) {
        self.sensor_time_secs = self.data.time();
        self.data.step();
    }

    /// The compiled model.
    pub fn model(&self) -> &MjModel {
        self.data.model()
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

    /// Number of links and joints.
    pub fn n_links(&self) -> usize {
        self.index.links.len()
    }
    /// Number of 1-DOF joints.
    pub fn n_joints(&self) -> usize {
        self.index.joints.len()
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

    /// Fills the exact (noise-free) observation from the current state.
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
        }
        if let Some(head) = self.index.links.first() {
            obs.head_position_m = d.xpos()[head.body];
            obs.head_quat = d.xquat()[head.body];
            let v = d.object_velocity(MjtObjBase::mjOBJ_BODY, head.body, false);
            obs.head_velocity_m_per_s = [v[3], v[4], v[5]];
        }
        // Sensor values come from the last complete evaluation: the start of the previous step,
        // unless a forward pass ran at this state (see ARCHITECTURE.md).
        obs.sensor_time_secs = self.sensor_time_secs;
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

/// A world with its controller and sensor noise: the step loop.
pub struct Simulation {
    /// The world.
    pub world: World,
    controller: Box<dyn Controller>,
    noise: SensorNoise,
    obs_true: Observation,
    /// What the controller saw at the latest step (measured values).
    pub obs: Observation,
    cmd: Command,
    steps: u64,
    /// Full state for controllers that ask for it.
    controller_state: Option<Snapshot>,
    /// Per-step work of the ground friction model.
    ground: Ground,
    /// Runaway-energy check (`[safety]`).
    energy_guard: EnergyGuard,
}

impl Simulation {
    /// The world with the built-in controller that `config` describes.
    pub fn new(config: &Config, world: World) -> Self {
        let controller = Box::new(TrajectoryController::from_config(config, world.n_joints()));
        Self::with_controller(config, world, controller)
    }

    /// The world with a controller of your own.
    pub fn with_controller(config: &Config, world: World, mut controller: Box<dyn Controller>) -> Self {
        let (nl, nj) = (world.n_links(), world.n_joints());
        controller.reset();
        let controller_state = controller.needs_full_state().then(|| Snapshot::new(nl, nj));
        let ground = Ground::new(config, &world);
        let energy_guard = EnergyGuard::new(config, &world);
        Self {
            ground,
            energy_guard,
            controller_state,
            noise: SensorNoise::new(&config.sensors, config.general.seed, nl, nj),
            obs_true: Observation::new(nl, nj),
            obs: Observation::new(nl, nj),
            cmd: Command::new(nj),
            controller,
            world,
            steps: 0,
        }
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The noise-free observation at the latest step.
    pub fn true_observation(&self) -> &Observation {
        &self.obs_true
    }

    /// The controller's command at the latest step.
    pub fn command(&self) -> &Command {
        &self.cmd
    }

    /// Observe, run the controller and write `ctrl` for the step that starts now. Called by
    /// [`Simulation::step`]; separate so a forward pass for recording can see the new controls.
    pub fn control(&mut self) {
        if self.controller_state.is_some() {
            self.world.forward();
        }
        self.world.observe_true(&mut self.obs_true);
        self.noise.measure(&self.obs_true, &mut self.obs);
        match self.controller_state.as_mut() {
            Some(state) => {
                state.read(&self.world, &self.obs_true, &self.obs);
                self.controller.update_with_state(&self.obs, state, &mut self.cmd);
            }
            None => self.controller.update(&self.obs, &mut self.cmd),
        }
        self.world.apply_command(&self.cmd);
        self.ground.before_step(&mut self.world);
    }

    /// Advances the physics by one timestep with the controls already written.
    pub fn advance(&mut self) -> Result<(), SimError> {
        let reached_secs = self.world.data.time() + self.world.model().opt().timestep;
        self.world.step();
        self.steps += 1;
        self.world.check_finite(self.steps, reached_secs)?;
        self.energy_guard.check(&mut self.world, self.steps, reached_secs)
    }

    /// One full step: [`Simulation::control`] then [`Simulation::advance`].
    pub fn step(&mut self) -> Result<(), SimError> {
        self.control();
        self.advance()
    }

    /// Runs MuJoCo's forward pass at the current state and controls, so that positions,
    /// velocities, accelerations, contacts, sensors and constraint forces all describe this
    /// instant, and reads them into `snapshot`.
    pub fn snapshot(&mut self, snapshot: &mut Snapshot) {
        self.world.forward();
        snapshot.read(&self.world, &self.obs_true, &self.obs);
        snapshot.link_region.copy_from_slice(self.ground.link_regions());
    }

    /// The ground model's per-step state (floor surfaces, the region under each link).
    pub fn ground(&self) -> &Ground {
        &self.ground
    }
}

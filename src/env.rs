//! A reinforcement-learning environment core: the snake of a config, stepped by an agent's
//! actions instead of a gait (`[env]` in the config). The Python package's Gymnasium
//! environments are thin wrappers around [`EnvCore`].
//!
//! One [`EnvCore::step`] holds the action for `env.control_period_secs` (a whole number of
//! physics steps), then observes. It allocates nothing: observations are written into a slice
//! the caller owns, so a vector of environments can step in parallel into one array.
//!
//! Observation layout, version 1 (see `default.toml`, `[env]`): measured joint angles and
//! velocities, exact head position, quaternion (w, x, y, z) and linear velocity, then
//! optionally measured per link IMU (accelerometer, gyro) and per joint force/torque sensors.
//! Sensor noise follows `[sensors]`, seeded by the `seed` of [`EnvCore::reset`].
//!
//! Reward per action: `forward_weight · progress − energy_weight · energy −
//! contact_force_weight · peak force` (see [`RewardTerms`]).

use crate::config::{self, Config, ConfigError, ConfigSource, ControlMethod, EnvAction, EnvPreset};
use crate::control::{Command, HeldCommand};
use crate::sim::{SimError, Simulation, SimulationState, World};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The random stream of the reset noise (the sensor models use streams below 3,000,000 of the
/// same seed).
const RESET_NOISE_STREAM: u64 = 3_000_000;

/// The reward terms and read-outs of one action.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RewardTerms {
    /// Displacement of the centre of mass during the action along the forward direction (the
    /// head's heading in the model before the reset noise) (m).
    pub forward_progress_m: f64,
    /// `forward_progress_m / control_period_secs` (m/s).
    pub forward_velocity_m_per_s: f64,
    /// Centre of mass after the action (m, world frame).
    pub x_position_m: f64,
    /// Centre of mass after the action (m, world frame).
    pub y_position_m: f64,
    /// Velocity of the centre of mass over the action (m/s, world frame).
    pub x_velocity_m_per_s: f64,
    /// Velocity of the centre of mass over the action (m/s, world frame).
    pub y_velocity_m_per_s: f64,
    /// Actuator energy: Σ over the physics steps of Σ_joints |τ·q̇|·dt (J), with τ and q̇
    /// read after each step.
    pub energy_j: f64,
    /// Largest contact normal force after the action's last physics step (N); NaN when the
    /// simulation diverged (no force to read).
    pub peak_contact_force_n: f64,
    /// Σ action² of the clipped action, in the action's units (normalised when
    /// `env.normalize_action`).
    pub ctrl_sum_sq: f64,
    /// `reward_forward_weight · forward velocity`.
    pub reward_forward: f64,
    /// `−reward_energy_weight · energy / control period` (mean power).
    pub reward_energy: f64,
    /// `−reward_contact_force_weight · peak force`.
    pub reward_contact_force: f64,
    /// `−reward_ctrl_cost_weight · Σ action²`.
    pub reward_ctrl: f64,
}

impl RewardTerms {
    /// The names of [`RewardTerms::values`], in order (the Python `info` keys).
    pub const NAMES: [&'static str; 13] = [
        "forward_progress_m",
        "forward_velocity_m_per_s",
        "x_position",
        "y_position",
        "x_velocity",
        "y_velocity",
        "energy_j",
        "peak_contact_force_n",
        "ctrl_sum_sq",
        "reward_forward",
        "reward_energy",
        "reward_contact_force",
        "reward_ctrl",
    ];

    /// Every term, in the order of [`RewardTerms::NAMES`].
    pub fn values(&self) -> [f64; 13] {
        [
            self.forward_progress_m,
            self.forward_velocity_m_per_s,
            self.x_position_m,
            self.y_position_m,
            self.x_velocity_m_per_s,
            self.y_velocity_m_per_s,
            self.energy_j,
            self.peak_contact_force_n,
            self.ctrl_sum_sq,
            self.reward_forward,
            self.reward_energy,
            self.reward_contact_force,
            self.reward_ctrl,
        ]
    }
}

/// What one action did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepOutcome {
    /// The weighted reward (the sum of the `reward_*` terms).
    pub reward: f64,
    /// Its terms.
    pub terms: RewardTerms,
    /// The episode ended (divergence, or the contact force bound).
    pub terminated: bool,
    /// The episode has reached `env.max_episode_secs` (also on every step after it).
    pub truncated: bool,
    /// Why it terminated, if it did.
    pub error: Option<String>,
}

/// One environment: the simulation (world, ground model, sensor models, contact estimator)
/// with the agent's held command as its controller, and the episode's bookkeeping. An action
/// is `substeps` physics steps ([`Simulation::control`] then [`Simulation::advance`]), then
/// the sensors are read at the instant reached; every physics instant is sensed and controlled
/// exactly once, at action boundaries too.
pub struct EnvCore {
    config: Config,
    sim: Simulation<HeldCommand>,
    substeps: u64,
    steps: u64,
    max_steps: u64,
    com: [f64; 3],
    /// Centre of mass at the episode's start (m).
    start_com: [f64; 3],
    /// The forward direction of the reward: the head's heading in the model's initial pose.
    forward_xy: [f64; 2],
    /// Physical action bounds (rad or N·m).
    lo: Vec<f64>,
    hi: Vec<f64>,
    /// The action space's bounds ([-1, 1] when normalised, else the physical ones).
    action_lo: Vec<f64>,
    action_hi: Vec<f64>,
    terminated: bool,
}

/// A saved state of an [`EnvCore`] ([`EnvCore::save_state`]): the simulation (engine state,
/// held action, sensor-noise streams and biases, contact estimator's filters, ground model)
/// and the episode's bookkeeping.
#[derive(Clone)]
pub struct EnvState {
    sim: SimulationState<HeldCommand>,
    steps: u64,
    com: [f64; 3],
    start_com: [f64; 3],
    terminated: bool,
}

impl EnvState {
    /// The saved engine state (`qpos`, `qvel`, `time`, …).
    pub fn world(&self) -> &crate::sim::WorldState {
        self.sim.world()
    }
}

/// The model of an environment: `config` with the physics of `env.preset` (the overrides of
/// [`config::ENV_FAST_PRESET`] for `"fast"`) and `control.method` taken from `env.action`.
///
/// # Errors
/// The preset's overrides make the config invalid (cannot happen for a valid config).
pub fn env_model_config(config: &Config) -> Result<Config, ConfigError> {
    let mut config = match config.env.preset {
        EnvPreset::Default => config.clone(),
        EnvPreset::Fast => {
            let sets: Vec<String> = config::ENV_FAST_PRESET.iter().map(|s| (*s).to_string()).collect();
            config::load_config_str(&config.to_toml_string(), ConfigSource::Toml, &sets)?
        }
    };
    config.control.method = config.env.action.control_method();
    Ok(config)
}

/// Rotates the unit quaternion `q` (w, x, y, z) by `angle_rad` about the world's vertical.
fn turn_about_vertical(q: [f64; 4], angle_rad: f64) -> [f64; 4] {
    let (s, c) = (0.5 * angle_rad).sin_cos();
    let [w, x, y, z] = q;
    // (c, 0, 0, s) ⊗ (w, x, y, z)
    [c * w - s * z, c * x - s * y, c * y + s * x, c * z + s * w]
}

impl EnvCore {
    /// Builds the world of `config` for the agent.
    ///
    /// # Errors
    /// A config error (also the `[env]` rules of [`Config::validate_env_use`]), or a model
    /// MuJoCo rejects.
    pub fn new(config: &Config) -> Result<Self, SimError> {
        config.validate_env_use()?;
        let config = env_model_config(config)?;
        config.validate_env_use()?;
        let world = World::from_config(&config)?;
        let nj = world.n_joints();
        let substeps = (config.env.control_period_secs / config.general.timestep_secs).round().max(1.0) as u64;
        let max_steps = ((config.env.max_episode_secs / config.env.control_period_secs) + 1e-9).floor().max(1.0) as u64;
        let (lo, hi) = match config.env.action {
            EnvAction::Position => {
                let r = config.joint_range_rad();
                (vec![-r; nj], vec![r; nj])
            }
            EnvAction::Torque => {
                let [a, b] = config.snake.torque_range_nm;
                (vec![a; nj], vec![b; nj])
            }
        };
        let (action_lo, action_hi) =
            if config.env.normalize_action { (vec![-1.0; nj], vec![1.0; nj]) } else { (lo.clone(), hi.clone()) };
        let forward_xy = world.head_heading_xy();
        // With contact estimation the sensors are read at every physics step: the estimator's
        // attitude filter integrates the gyro step by step, as in `simserpent run`.
        let held = HeldCommand { command: Command::new(nj), sense_every_step: config.estimation.enabled };
        let mut env = Self {
            sim: Simulation::with_typed_controller(&config, world, held),
            substeps,
            steps: 0,
            max_steps,
            com: [0.0; 3],
            start_com: [0.0; 3],
            forward_xy,
            lo,
            hi,
            action_lo,
            action_hi,
            terminated: false,
            config,
        };
        env.reset_state(env.config.general.seed)?;
        Ok(env)
    }

    /// The config the environment runs (with the preset applied and `control.method` from
    /// `env.action`).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The world (read only).
    pub fn world(&self) -> &World {
        self.sim.world()
    }

    /// The MJCF of the world.
    pub fn mjcf(&self) -> &str {
        &self.sim.world().mjcf
    }

    /// Length of an action (one value per joint).
    pub fn action_size(&self) -> usize {
        self.sim.world().n_joints()
    }

    /// The action space's bounds (lower, upper) per joint: [-1, 1] with
    /// `env.normalize_action`, else the physical bounds. Actions are clipped to them.
    pub fn action_bounds(&self) -> (&[f64], &[f64]) {
        (&self.action_lo, &self.action_hi)
    }

    /// The physical bounds (rad or N·m) an action maps onto.
    pub fn physical_action_bounds(&self) -> (&[f64], &[f64]) {
        (&self.lo, &self.hi)
    }

    /// Physics steps per action.
    pub fn substeps(&self) -> u64 {
        self.substeps
    }

    /// Actions per episode before truncation.
    pub fn max_episode_steps(&self) -> u64 {
        self.max_steps
    }

    /// Actions taken in this episode.
    pub fn episode_steps(&self) -> u64 {
        self.steps
    }

    /// Simulated time (s).
    pub fn time_secs(&self) -> f64 {
        self.sim.world().time_secs()
    }

    /// Length of the observation vector.
    pub fn observation_size(&self) -> usize {
        observation_names(&self.config, self.sim.world().n_links(), self.sim.world().n_joints()).len()
    }

    /// The name of each observation element, in order (the versioned layout).
    pub fn observation_names(&self) -> Vec<String> {
        observation_names(&self.config, self.sim.world().n_links(), self.sim.world().n_joints())
    }

    /// Centre of mass of the links (m).
    pub fn centre_of_mass(&self) -> [f64; 3] {
        self.sim.world().centre_of_mass_m()
    }

    /// Centre of mass of the links at the start of the episode (m; part of a saved state).
    pub fn start_centre_of_mass(&self) -> [f64; 3] {
        self.start_com
    }

    /// The forward direction of the reward (unit vector in the xy-plane).
    pub fn forward_xy(&self) -> [f64; 2] {
        self.forward_xy
    }

    /// Starts a new episode from the initial pose with the reset noise of `env` drawn from
    /// `seed`, which also seeds the sensor noise. Writes the first observation into `obs_out`
    /// (length [`EnvCore::observation_size`]).
    ///
    /// # Errors
    /// The world cannot be reset (a model without a usable keyframe).
    ///
    /// # Panics
    /// If `obs_out` has the wrong length.
    pub fn reset(&mut self, seed: u64, obs_out: &mut [f64]) -> Result<(), SimError> {
        self.reset_state(seed)?;
        self.write_observation(obs_out);
        Ok(())
    }

    fn reset_state(&mut self, seed: u64) -> Result<(), SimError> {
        // No command until the first action.
        self.sim.controller_mut().command = Command::new(self.sim.world().n_joints());
        let (scale, heading) = (self.config.env.reset_noise_scale, self.config.env.reset_heading_noise_rad);
        self.sim.reset_with(seed, |world| {
            if scale == 0.0 && heading == 0.0 {
                return;
            }
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(RESET_NOISE_STREAM);
            // Always the same draws in the same order, whichever parts are switched off.
            let joints: Vec<(usize, usize)> = world.index.joints.iter().map(|j| (j.qpos_adr, j.dof_adr)).collect();
            let angle_noise: Vec<f64> = joints.iter().map(|_| rng.random_range(-1.0..=1.0) * scale).collect();
            let velocity_noise: Vec<f64> =
                joints.iter().map(|_| scale * rng.sample::<f64, _>(StandardNormal)).collect();
            let turn = rng.random_range(-1.0..=1.0) * heading;
            let qpos = world.qpos_mut();
            for ((q, _), n) in joints.iter().zip(&angle_noise) {
                qpos[*q] += n;
            }
            if let Some(adr) = world.index.head_free_qpos_adr {
                let qpos = world.qpos_mut();
                let q = [qpos[adr + 3], qpos[adr + 4], qpos[adr + 5], qpos[adr + 6]];
                let turned = turn_about_vertical(q, turn);
                qpos[adr + 3..adr + 7].copy_from_slice(&turned);
            }
            let qvel = world.qvel_mut();
            for ((_, d), n) in joints.iter().zip(&velocity_noise) {
                qvel[*d] += n;
            }
        })?;
        self.steps = 0;
        self.terminated = false;
        self.com = self.centre_of_mass();
        self.start_com = self.com;
        Ok(())
    }

    /// A copy of the whole state (engine, held action, sensor-noise streams and biases, contact
    /// estimator, ground model, episode bookkeeping): [`EnvCore::restore_state`] continues bit
    /// for bit from here.
    pub fn save_state(&self) -> EnvState {
        EnvState {
            sim: self.sim.save(),
            steps: self.steps,
            com: self.com,
            start_com: self.start_com,
            terminated: self.terminated,
        }
    }

    /// Goes back to a state saved from this environment, or from another environment of the
    /// same config.
    ///
    /// # Errors
    /// The state belongs to a world of another model.
    pub fn restore_state(&mut self, state: &EnvState) -> Result<(), SimError> {
        self.sim.restore(&state.sim)?;
        self.steps = state.steps;
        self.com = state.com;
        self.start_com = state.start_com;
        self.terminated = state.terminated;
        Ok(())
    }

    /// The contact estimates of the latest sensed instant (`[estimation] enabled`; inactive,
    /// all zero, otherwise): per link external, floor and obstacle force, contact flag and
    /// contact point. The observation has some of them with `env.observe_contact_estimates`.
    pub fn contact_estimates(&self) -> &crate::estimation::ContactEstimates {
        &self.sim.observation().contacts
    }

    /// Holds `action` (clipped to [`EnvCore::action_bounds`], mapped onto the physical bounds
    /// when normalised) for one control period and writes the observation after it into
    /// `obs_out`. After a terminated step, further steps do nothing but repeat the last
    /// observation (with `terminated` set again) until [`EnvCore::reset`]; after truncation
    /// (a time limit, the state is still valid) the episode goes on, each step again
    /// `truncated`, as Gymnasium's MuJoCo environments do.
    ///
    /// # Panics
    /// If `action` or `obs_out` has the wrong length.
    pub fn step(&mut self, action: &[f64], obs_out: &mut [f64]) -> StepOutcome {
        assert_eq!(action.len(), self.action_size(), "action length");
        if self.terminated {
            self.write_observation(obs_out);
            return StepOutcome {
                terminated: true,
                terms: RewardTerms { peak_contact_force_n: f64::NAN, ..RewardTerms::default() },
                error: Some("the episode has ended: call reset".into()),
                ..StepOutcome::default()
            };
        }
        let held = &mut self.sim.controller_mut().command;
        let block = match self.config.env.action {
            EnvAction::Position => &mut held.position_rad,
            EnvAction::Torque => &mut held.torque_nm,
        };
        let gear = self.config.control.torque_gear;
        let mut ctrl_sum_sq = 0.0;
        for (j, a) in action.iter().enumerate() {
            // NaN stays NaN (MuJoCo then reports a bad control, which terminates the episode).
            let clipped = a.max(self.action_lo[j]).min(self.action_hi[j]);
            ctrl_sum_sq += clipped * clipped;
            let physical = if self.config.env.normalize_action {
                self.lo[j] + 0.5 * (clipped + 1.0) * (self.hi[j] - self.lo[j])
            } else {
                clipped
            };
            block[j] = if self.config.control.method == ControlMethod::Torque { physical / gear } else { physical };
            if a.is_nan() {
                block[j] = f64::NAN;
            }
        }
        // The action's physics steps. Each instant is sensed and controlled once: the first
        // was sensed at the end of the previous action (or the reset), and the one this action
        // ends at is sensed below and controlled by the next action — as in one long
        // `simserpent run` that holds the same commands.
        let mut energy_j = 0.0;
        let mut error = None;
        let dt = self.sim.world().timestep_secs();
        for _ in 0..self.substeps {
            self.sim.control();
            if let Err(e) = self.sim.advance() {
                error = Some(e.to_string());
                break;
            }
            // Power after each step: MuJoCo's actuator torque of the step times the joint
            // velocity it reached.
            energy_j += self.sim.world().actuator_power_w() * dt;
        }
        self.steps += 1;
        let e = &self.config.env;
        let period = e.control_period_secs;
        let com = self.centre_of_mass();
        let (dx, dy) = (com[0] - self.com[0], com[1] - self.com[1]);
        let progress = dx * self.forward_xy[0] + dy * self.forward_xy[1];
        self.com = com;
        let peak = if error.is_none() {
            self.sim.world().peak_contact_force_n().max(self.sim.ground().peak_own_normal_force_n())
        } else {
            f64::NAN
        };
        let mut terms = RewardTerms {
            forward_progress_m: progress,
            forward_velocity_m_per_s: progress / period,
            x_position_m: com[0],
            y_position_m: com[1],
            x_velocity_m_per_s: dx / period,
            y_velocity_m_per_s: dy / period,
            energy_j,
            peak_contact_force_n: peak,
            ctrl_sum_sq,
            reward_forward: e.reward_forward_weight * progress / period,
            reward_energy: -e.reward_energy_weight * energy_j / period,
            reward_contact_force: if e.reward_contact_force_weight > 0.0 {
                -e.reward_contact_force_weight * peak
            } else {
                0.0
            },
            reward_ctrl: -e.reward_ctrl_cost_weight * ctrl_sum_sq,
        };
        let mut reward = terms.reward_forward + terms.reward_energy + terms.reward_contact_force + terms.reward_ctrl;
        if error.is_none() && e.terminate_contact_force_n > 0.0 && peak > e.terminate_contact_force_n {
            error = Some(format!(
                "contact normal force {peak:.3} N exceeds env.terminate_contact_force_n = {} N at t = {:.6} s",
                e.terminate_contact_force_n,
                self.sim.world().time_secs()
            ));
        }
        let terminated = error.is_some();
        if terminated && !reward.is_finite() {
            reward = 0.0;
            terms.reward_contact_force = 0.0;
        }
        let truncated = !terminated && self.steps >= self.max_steps;
        self.terminated = terminated;
        if error.is_none() {
            self.sim.sense();
        }
        self.write_observation(obs_out);
        StepOutcome { reward, terms, terminated, truncated, error }
    }

    /// Writes the current observation (version 1 layout); non-finite values (a diverged
    /// state) become 0.
    fn write_observation(&self, out: &mut [f64]) {
        let o = self.sim.observation();
        let mut k = 0;
        let mut put = |x: f64| {
            out[k] = if x.is_finite() { x } else { 0.0 };
            k += 1;
        };
        o.joint_angle_rad.iter().for_each(|x| put(*x));
        o.joint_velocity_rad_per_s.iter().for_each(|x| put(*x));
        if self.config.env.exclude_current_positions_from_observation {
            put(o.head_position_m[2]);
        } else {
            o.head_position_m.iter().for_each(|x| put(*x));
        }
        o.head_quat.iter().for_each(|x| put(*x));
        o.head_velocity_m_per_s.iter().for_each(|x| put(*x));
        if self.config.env.observe_imu {
            o.imu_accel_m_per_s2.iter().flatten().for_each(|x| put(*x));
            o.imu_gyro_rad_per_s.iter().flatten().for_each(|x| put(*x));
        }
        if self.config.env.observe_joint_force_torque {
            o.joint_force_n.iter().flatten().for_each(|x| put(*x));
            o.joint_torque_nm.iter().flatten().for_each(|x| put(*x));
        }
        if self.config.env.observe_contact_estimates {
            let c = &o.contacts;
            for i in 0..c.n_links() {
                put(c.obstacle_force_n[i][0]);
                put(c.obstacle_force_n[i][1]);
                put(if c.contact[i] { 1.0 } else { 0.0 });
                put(c.contact_point_along_m[i].unwrap_or(0.0));
            }
        }
        assert_eq!(k, out.len(), "observation length");
    }
}

/// The observation element names of the version-1 layout.
pub fn observation_names(config: &Config, n_links: usize, n_joints: usize) -> Vec<String> {
    let mut names = Vec::new();
    let joint = |j: usize| format!("joint_{:02}", j + 1);
    names.extend((0..n_joints).map(|j| format!("{}_angle_rad", joint(j))));
    names.extend((0..n_joints).map(|j| format!("{}_velocity_rad_per_s", joint(j))));
    if config.env.exclude_current_positions_from_observation {
        names.push("head_position_z_m".into());
    } else {
        names.extend(["x", "y", "z"].map(|a| format!("head_position_{a}_m")));
    }
    names.extend(["w", "x", "y", "z"].map(|a| format!("head_quat_{a}")));
    names.extend(["x", "y", "z"].map(|a| format!("head_velocity_{a}_m_per_s")));
    if config.env.observe_imu {
        for i in 0..n_links {
            names.extend(["x", "y", "z"].map(|a| format!("link_{i:02}_accelerometer_{a}_m_per_s2")));
        }
        for i in 0..n_links {
            names.extend(["x", "y", "z"].map(|a| format!("link_{i:02}_gyro_{a}_rad_per_s")));
        }
    }
    if config.env.observe_joint_force_torque {
        for j in 0..n_joints {
            names.extend(["x", "y", "z"].map(|a| format!("{}_force_{a}_n", joint(j))));
        }
        for j in 0..n_joints {
            names.extend(["x", "y", "z"].map(|a| format!("{}_torque_{a}_nm", joint(j))));
        }
    }
    if config.env.observe_contact_estimates {
        for i in 0..n_links {
            names.extend([
                format!("link_{i:02}_obstacle_force_x_n"),
                format!("link_{i:02}_obstacle_force_y_n"),
                format!("link_{i:02}_obstacle_contact"),
                format!("link_{i:02}_obstacle_contact_point_along_m"),
            ]);
        }
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigSource, load_config_str};

    fn config(extra: &[&str]) -> Config {
        let mut sets: Vec<String> = vec!["snake.n_links=5".into(), "terrain.kind=\"none\"".into()];
        sets.extend(extra.iter().map(|s| s.to_string()));
        load_config_str("", ConfigSource::Toml, &sets).expect("valid test config")
    }

    fn rollout(env: &mut EnvCore, seed: u64, n: usize) -> Vec<f64> {
        let mut obs = vec![0.0; env.observation_size()];
        env.reset(seed, &mut obs).expect("reset");
        let mut all = obs.clone();
        for k in 0..n {
            let a: Vec<f64> = (0..env.action_size()).map(|j| 0.5 * ((k + j) as f64 * 0.7).sin()).collect();
            let out = env.step(&a, &mut obs);
            assert!(!out.terminated, "{:?}", out.error);
            all.extend_from_slice(&obs);
            all.push(out.reward);
        }
        all
    }

    #[test]
    fn env_core_is_send() {
        fn is_send<T: Send>() {}
        is_send::<EnvCore>();
    }

    #[test]
    fn observation_layout_matches_names() {
        let c = config(&["env.observe_imu=true", "env.observe_joint_force_torque=true"]);
        let env = EnvCore::new(&c).expect("env");
        let (nl, nj) = (5, 4);
        // Head z (x and y left out by default), quaternion, velocity.
        assert_eq!(env.observation_size(), 2 * nj + 8 + 6 * nl + 6 * nj);
        assert_eq!(env.action_size(), nj);
        assert_eq!(env.substeps(), 20);
        assert_eq!(env.max_episode_steps(), 500);
    }

    #[test]
    fn contact_estimates_in_the_observation_without_changing_the_physics() {
        let mut plain = EnvCore::new(&config(&[])).expect("env");
        let mut est =
            EnvCore::new(&config(&["estimation.enabled=true", "env.observe_contact_estimates=true"])).expect("env");
        assert_eq!(est.observation_size(), plain.observation_size() + 4 * 5);
        let names = est.observation_names();
        assert_eq!(names[names.len() - 4], "link_04_obstacle_force_x_n");
        assert_eq!(names[names.len() - 1], "link_04_obstacle_contact_point_along_m");
        let _ = rollout(&mut plain, 1, 10);
        let _ = rollout(&mut est, 1, 10);
        // The estimator reads the sensors at every step; the physics stays the same bit for bit.
        assert_eq!(plain.world().data().qpos(), est.world().data().qpos());
        assert!(est.contact_estimates().active);
        assert!(!plain.contact_estimates().active);
        let err = EnvCore::new(&config(&["env.observe_contact_estimates=true"])).err().expect("needs estimation");
        assert!(err.to_string().contains("env.observe_contact_estimates"), "{err}");
    }

    #[test]
    fn same_seed_same_episode_and_noise_changes_with_seed() {
        let c = config(&["sensors.noise_enabled=true", "sensors.joint_angle.std=0.01"]);
        let mut env = EnvCore::new(&c).expect("env");
        let a = rollout(&mut env, 3, 10);
        let b = rollout(&mut env, 3, 10);
        assert_eq!(a, b);
        let other = rollout(&mut env, 4, 10);
        assert_ne!(a, other);
        let mut fresh = EnvCore::new(&c).expect("env");
        assert_eq!(rollout(&mut fresh, 3, 10), a);
    }

    #[test]
    fn reset_restores_directional_pair_friction_and_viscous_ground() {
        // Directional friction changes the model's pair friction during an episode; a reset
        // must undo that, or the next episode would start from another friction state.
        for model in ["directional", "viscous"] {
            let c = config(&[&format!("ground.model=\"{model}\"")]);
            let mut env = EnvCore::new(&c).expect("env");
            let first = rollout(&mut env, 2, 30);
            let second = rollout(&mut env, 2, 30);
            assert_eq!(first, second, "{model}");
        }
    }

    #[test]
    fn travelling_wave_moves_forward_and_truncates() {
        let c = config(&[
            "env.max_episode_secs=3.0",
            "env.reward_energy_weight=0.1",
            "env.normalize_action=false",
            "env.reward_ctrl_cost_weight=0.0",
        ]);
        let mut env = EnvCore::new(&c).expect("env");
        let mut obs = vec![0.0; env.observation_size()];
        env.reset(1, &mut obs).expect("reset");
        let (mut total_progress, mut total_energy, mut total_peak) = (0.0, 0.0, 0.0);
        let mut t = 0.0;
        for k in 0..env.max_episode_steps() {
            t += 0.02;
            let a: Vec<f64> = (0..4).map(|j| 0.5 * (std::f64::consts::TAU * t - j as f64 * 0.8).sin()).collect();
            let out = env.step(&a, &mut obs);
            total_progress += out.terms.forward_progress_m;
            total_energy += out.terms.energy_j;
            // Rates: velocity (m/s) and mean power (W) over the 0.02 s control period.
            let expected = out.terms.forward_progress_m / 0.02 - 0.1 * out.terms.energy_j / 0.02;
            assert!((out.reward - expected).abs() < 1e-9);
            // Computed at every step (0 only when no contact is active: MuJoCo's soft floor lets
            // an undulating snake hop, see ARCHITECTURE.md).
            assert!(out.terms.peak_contact_force_n >= 0.0);
            total_peak += out.terms.peak_contact_force_n;
            assert_eq!(out.truncated, k + 1 == env.max_episode_steps());
            assert!(!out.terminated);
        }
        assert!(total_progress > 0.01, "progress {total_progress}");
        assert!(total_energy > 0.0);
        assert!(total_peak > 0.0, "on the floor: contact forces carry the weight");
        assert!((env.time_secs() - 3.0).abs() < 1e-9);
        // A time limit does not end the physics: stepping on stays truncated, not terminated.
        let after = env.step(&[0.0; 4], &mut obs);
        assert!(after.truncated && !after.terminated, "{after:?}");
    }

    #[test]
    fn reset_noise_depends_on_the_seed_only() {
        let c = config(&[]);
        assert!(c.env.reset_noise_scale > 0.0 && c.env.reset_heading_noise_rad > 0.0);
        let mut env = EnvCore::new(&c).expect("env");
        let mut a = vec![0.0; env.observation_size()];
        let mut b = a.clone();
        env.reset(7, &mut a).expect("reset");
        let q7 = env.world().data().qpos().to_vec();
        env.reset(8, &mut b).expect("reset");
        assert_ne!(a, b);
        env.reset(7, &mut b).expect("reset");
        assert_eq!(a, b);
        assert_eq!(env.world().data().qpos(), &q7[..]);
        // The joint angles move by at most the scale from the keyframe (0 for the default pose).
        let joints: Vec<usize> = env.world().index.joints.iter().map(|j| j.qpos_adr).collect();
        let initial = &env.world().initial_joint_angles_rad;
        for (k, q) in joints.iter().enumerate() {
            assert!((q7[*q] - initial[k]).abs() <= c.env.reset_noise_scale, "joint {k}");
        }
        // Without noise every seed starts from the same state.
        let quiet = config(&["env.reset_noise_scale=0.0", "env.reset_heading_noise_rad=0.0"]);
        let mut env = EnvCore::new(&quiet).expect("env");
        env.reset(7, &mut a).expect("reset");
        env.reset(8, &mut b).expect("reset");
        assert_eq!(a, b);
    }

    #[test]
    fn saved_state_continues_bit_for_bit() {
        for floor in ["mujoco", "stick_slip"] {
            let c = config(&[
                "sensors.noise_enabled=true",
                "sensors.joint_angle.std=0.01",
                &format!("physics.floor_friction=\"{floor}\""),
            ]);
            let mut env = EnvCore::new(&c).expect("env");
            let mut obs = vec![0.0; env.observation_size()];
            env.reset(5, &mut obs).expect("reset");
            let act = |k: usize| -> Vec<f64> { (0..4).map(|j| (0.3 * (k + j) as f64).sin()).collect() };
            for k in 0..5 {
                env.step(&act(k), &mut obs);
            }
            let saved = env.save_state();
            let mut first = Vec::new();
            for k in 5..15 {
                let out = env.step(&act(k), &mut obs);
                first.extend_from_slice(&obs);
                first.push(out.reward);
            }
            // Another branch, then back.
            env.step(&[1.0, -1.0, 1.0, -1.0], &mut obs);
            env.restore_state(&saved).expect("restore");
            let mut second = Vec::new();
            for k in 5..15 {
                let out = env.step(&act(k), &mut obs);
                second.extend_from_slice(&obs);
                second.push(out.reward);
            }
            assert_eq!(first, second, "{floor}");
            // Into a second environment of the same config.
            let mut other = EnvCore::new(&c).expect("env");
            other.restore_state(&saved).expect("restore");
            let mut third = Vec::new();
            for k in 5..15 {
                let out = other.step(&act(k), &mut obs);
                third.extend_from_slice(&obs);
                third.push(out.reward);
            }
            assert_eq!(first, third, "{floor}");
        }
    }

    #[test]
    fn normalised_actions_map_onto_the_joint_range() {
        let c = config(&["env.reset_noise_scale=0.0", "env.reset_heading_noise_rad=0.0"]);
        let mut env = EnvCore::new(&c).expect("env");
        assert_eq!(env.action_bounds().0, &[-1.0; 4]);
        let r = c.joint_range_rad();
        let mut obs = vec![0.0; env.observation_size()];
        env.reset(0, &mut obs).expect("reset");
        let out = env.step(&[1.0, -1.0, 0.5, 3.0], &mut obs);
        let held = &env.sim.controller().command.position_rad;
        for (got, want) in held.iter().zip([r, -r, 0.5 * r, r]) {
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
        // Σ a² of the clipped action, weighted by the default 1e-4.
        assert!((out.terms.ctrl_sum_sq - 3.25).abs() < 1e-12);
        assert!((out.terms.reward_ctrl + 3.25e-4).abs() < 1e-15);
        let names = env.observation_names();
        assert!(!names.iter().any(|n| n == "head_position_x_m" || n == "head_position_y_m"));
        assert!(names.iter().any(|n| n == "head_position_z_m"));
    }

    #[test]
    fn fast_preset_changes_only_the_listed_physics() {
        let c = config(&["env.preset=\"fast\""]);
        let env = EnvCore::new(&c).expect("env");
        let default = EnvCore::new(&config(&[])).expect("env");
        let preset = config(crate::config::ENV_FAST_PRESET);
        assert_eq!(env.config().general, preset.general);
        assert_eq!(env.config().physics, preset.physics);
        assert_eq!(env.config().snake, default.config().snake);
        assert!(env.substeps() < default.substeps());
    }

    #[test]
    fn torque_actions_are_clipped_and_nan_terminates() {
        let c = config(&["env.action=\"torque\"", "env.normalize_action=false"]);
        let mut env = EnvCore::new(&c).expect("env");
        let (lo, hi) = env.action_bounds();
        assert_eq!(hi[0], c.snake.torque_range_nm[1]);
        assert_eq!(lo[0], c.snake.torque_range_nm[0]);
        let mut obs = vec![0.0; env.observation_size()];
        env.reset(0, &mut obs).expect("reset");
        let out = env.step(&[1e6, -1e6, 0.0, 0.0], &mut obs);
        assert!(!out.terminated, "{:?}", out.error);
        let out = env.step(&[f64::NAN, 0.0, 0.0, 0.0], &mut obs);
        assert!(out.terminated);
        assert!(out.error.as_deref().unwrap_or("").contains("mjWARN_BADCTRL"), "{:?}", out.error);
        assert!(obs.iter().all(|x| x.is_finite()));
    }

    #[test]
    fn control_period_must_be_whole_timesteps() {
        let c = config(&["env.control_period_secs=0.0015"]);
        let e = EnvCore::new(&c).err().expect("rejected").to_string();
        assert!(e.contains("env.control_period_secs") && e.contains("whole number"), "{e}");
    }

    #[test]
    fn contact_force_term_and_termination() {
        let c = config(&["env.reward_contact_force_weight=0.5", "env.terminate_contact_force_n=1e-6"]);
        let mut env = EnvCore::new(&c).expect("env");
        let mut obs = vec![0.0; env.observation_size()];
        env.reset(0, &mut obs).expect("reset");
        let out = env.step(&[0.0; 4], &mut obs);
        // Resting on the floor: the weight is carried by contacts.
        assert!(out.terms.peak_contact_force_n > 0.0);
        assert!(out.terminated);
        assert!(out.error.as_deref().unwrap_or("").contains("env.terminate_contact_force_n"));
    }
}

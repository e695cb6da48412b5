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

use crate::config::{Config, ControlMethod, EnvAction};
use crate::control::{Command, HeldCommand};
use crate::sim::{LoopPlan, Observer, SimError, Simulation, StepView, World};

/// The reward terms of one action, before weighting.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RewardTerms {
    /// Displacement of the centre of mass along the head's heading at reset (m).
    pub forward_progress_m: f64,
    /// Actuator energy: Σ over the physics steps of Σ_joints |τ·q̇|·dt (J), with τ and q̇
    /// read after each step.
    pub energy_j: f64,
    /// Largest contact normal force after the action's last physics step (N); 0 when its
    /// weight is 0 and no contact-force termination is configured (not computed then).
    pub peak_contact_force_n: f64,
}

/// What one action did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepOutcome {
    /// The weighted reward.
    pub reward: f64,
    /// Its terms.
    pub terms: RewardTerms,
    /// The episode ended (divergence, or the contact force bound).
    pub terminated: bool,
    /// The episode reached `env.max_episode_secs`.
    pub truncated: bool,
    /// Why it terminated, if it did.
    pub error: Option<String>,
}

/// One environment: the simulation (world, ground model, sensor models) with the agent's
/// held command as its controller, and the episode's bookkeeping. An action is the step loop
/// run for `substeps` physics steps ([`Simulation::run`]).
pub struct EnvCore {
    config: Config,
    sim: Simulation<HeldCommand>,
    substeps: u64,
    steps: u64,
    max_steps: u64,
    com: [f64; 3],
    heading: [f64; 2],
    lo: Vec<f64>,
    hi: Vec<f64>,
    done: bool,
}

/// Adds up the actuator energy of an action: the power after each physics step (MuJoCo's
/// joint-space actuator torque of the step times the joint velocity it reached), times dt.
#[derive(Default)]
struct EnergyMeter {
    energy_j: f64,
}

impl Observer<SimError> for EnergyMeter {
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), SimError> {
        if view.k > 0 {
            self.energy_j += view.world.actuator_power_w() * view.world.timestep_secs();
        }
        Ok(())
    }
}

/// The model of an environment: `config` with `control.method` taken from `env.action`.
pub fn env_model_config(config: &Config) -> Config {
    let mut config = config.clone();
    config.control.method = config.env.action.control_method();
    config
}

impl EnvCore {
    /// Builds the world of `config` for the agent.
    ///
    /// # Errors
    /// A config error (also the `[env]` rules of [`Config::validate_env_use`]), or a model
    /// MuJoCo rejects.
    pub fn new(config: &Config) -> Result<Self, SimError> {
        config.validate_env_use()?;
        let config = env_model_config(config);
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
        let held = HeldCommand { command: Command::new(nj) };
        let mut env = Self {
            sim: Simulation::with_typed_controller(&config, world, held),
            substeps,
            steps: 0,
            max_steps,
            com: [0.0; 3],
            heading: [1.0, 0.0],
            lo,
            hi,
            done: false,
            config,
        };
        env.reset_state(env.config.general.seed)?;
        Ok(env)
    }

    /// The config the environment runs (with `control.method` from `env.action`).
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

    /// Action bounds (lower, upper) per joint; actions are clipped to them.
    pub fn action_bounds(&self) -> (&[f64], &[f64]) {
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

    /// Starts a new episode from the initial pose; `seed` seeds the sensor noise. Writes the
    /// first observation into `obs_out` (length [`EnvCore::observation_size`]).
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
        self.sim.reset(seed)?;
        self.steps = 0;
        self.done = false;
        self.com = self.centre_of_mass();
        self.heading = self.sim.world().head_heading_xy();
        Ok(())
    }

    /// Holds `action` (clipped to [`EnvCore::action_bounds`]) for one control period and
    /// writes the observation after it into `obs_out`. After a terminated or truncated step,
    /// further steps do nothing but repeat the last observation (with `terminated`/`truncated`
    /// set again) until [`EnvCore::reset`].
    ///
    /// # Panics
    /// If `action` or `obs_out` has the wrong length.
    pub fn step(&mut self, action: &[f64], obs_out: &mut [f64]) -> StepOutcome {
        assert_eq!(action.len(), self.action_size(), "action length");
        if self.done {
            self.write_observation(obs_out);
            return StepOutcome {
                terminated: true,
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
        for (j, a) in action.iter().enumerate() {
            // NaN stays NaN (MuJoCo then reports a bad control, which terminates the episode).
            let clipped = a.max(self.lo[j]).min(self.hi[j]);
            block[j] = if self.config.control.method == ControlMethod::Torque { clipped / gear } else { clipped };
            if a.is_nan() {
                block[j] = f64::NAN;
            }
        }
        let mut meter = EnergyMeter::default();
        let plan = LoopPlan { steps: self.substeps, record_every_n_steps: 0 };
        let mut error = self.sim.run(plan, &mut [&mut meter]).err().map(|e| e.to_string());
        let energy_j = meter.energy_j;
        self.steps += 1;
        let e = &self.config.env;
        let com = self.centre_of_mass();
        let progress = (com[0] - self.com[0]) * self.heading[0] + (com[1] - self.com[1]) * self.heading[1];
        self.com = com;
        let want_force = e.reward_contact_force_weight > 0.0 || e.terminate_contact_force_n > 0.0;
        let peak = if want_force && error.is_none() { self.sim.world().peak_contact_force_n() } else { 0.0 };
        let terms = RewardTerms { forward_progress_m: progress, energy_j, peak_contact_force_n: peak };
        let mut reward = e.reward_forward_weight * progress
            - e.reward_energy_weight * energy_j
            - e.reward_contact_force_weight * peak;
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
        }
        let truncated = !terminated && self.steps >= self.max_steps;
        self.done = terminated || truncated;
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
        o.head_position_m.iter().for_each(|x| put(*x));
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
        assert_eq!(k, out.len(), "observation length");
    }
}

/// The observation element names of the version-1 layout.
pub fn observation_names(config: &Config, n_links: usize, n_joints: usize) -> Vec<String> {
    let mut names = Vec::new();
    let joint = |j: usize| format!("joint_{:02}", j + 1);
    names.extend((0..n_joints).map(|j| format!("{}_angle_rad", joint(j))));
    names.extend((0..n_joints).map(|j| format!("{}_velocity_rad_per_s", joint(j))));
    names.extend(["x", "y", "z"].map(|a| format!("head_position_{a}_m")));
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
        assert_eq!(env.observation_size(), 2 * nj + 10 + 6 * nl + 6 * nj);
        assert_eq!(env.action_size(), nj);
        assert_eq!(env.substeps(), 20);
        assert_eq!(env.max_episode_steps(), 500);
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
        let c = config(&["env.max_episode_secs=3.0", "env.reward_energy_weight=0.1"]);
        let mut env = EnvCore::new(&c).expect("env");
        let mut obs = vec![0.0; env.observation_size()];
        env.reset(1, &mut obs).expect("reset");
        let (mut total_progress, mut total_energy) = (0.0, 0.0);
        let mut t = 0.0;
        for k in 0..env.max_episode_steps() {
            t += 0.02;
            let a: Vec<f64> = (0..4).map(|j| 0.5 * (std::f64::consts::TAU * t - j as f64 * 0.8).sin()).collect();
            let out = env.step(&a, &mut obs);
            total_progress += out.terms.forward_progress_m;
            total_energy += out.terms.energy_j;
            let expected = out.terms.forward_progress_m - 0.1 * out.terms.energy_j;
            assert!((out.reward - expected).abs() < 1e-12);
            assert_eq!(out.truncated, k + 1 == env.max_episode_steps());
            assert!(!out.terminated);
        }
        assert!(total_progress > 0.01, "progress {total_progress}");
        assert!(total_energy > 0.0);
        assert!((env.time_secs() - 3.0).abs() < 1e-9);
        let after = env.step(&[0.0; 4], &mut obs);
        assert!(after.terminated);
    }

    #[test]
    fn torque_actions_are_clipped_and_nan_terminates() {
        let c = config(&["env.action=\"torque\""]);
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

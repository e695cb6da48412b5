//! Control: the [`Controller`] trait, joint trajectories (gaits) and the built-in controllers.
//!
//! Pure Rust: controllers see an [`Observation`] (plain numbers) and write a [`Command`]; they
//! never touch MuJoCo. The simulation calls [`Controller::update`] once per physics step, before
//! the step, with the state at the start of that step (see ARCHITECTURE.md for the exact order).

mod bilateral_compliance;
pub mod contact_jacobian;
mod directional_admittance;
mod follow_the_leader_reflex;
mod gait;
mod heading_hold;
mod jam_resolution;
mod keys;
mod path;
mod pid;

pub use bilateral_compliance::{BilateralCompliance, admissible_interval};
pub use directional_admittance::DirectionalAdmittance;
pub use follow_the_leader_reflex::FollowTheLeaderReflex;
pub use gait::{
    FormClosureShift, Hold, JointTrajectory, SineWave, Still, TwoPlaneWave, serpenoid, trajectory_from_config,
};
pub use heading_hold::HeadingHold;
pub use jam_resolution::{JamResolution, Resolution};
pub use keys::{UnusedKey, effective_controller, nothing_moves, unused_key_rules, unused_keys};
pub use path::{Guidance, PathFollowing};
pub use pid::Pid;

use crate::config::{Config, ControlMethod, JointAxes};

pub use crate::state::Observation;

/// What a controller writes: one command per joint for each actuator kind. Only the kind that
/// the model's `control.method` gave non-zero gains has any effect; the others are sent too
/// (a torque command always acts).
#[derive(Debug, Clone, Default)]
pub struct Command {
    /// Torque motor commands (N·m before the gear).
    pub torque_nm: Vec<f64>,
    /// Position servo set-points (rad).
    pub position_rad: Vec<f64>,
    /// Velocity servo set-points (rad/s).
    pub velocity_rad_per_s: Vec<f64>,
    /// Integrated-velocity servo commands (rad/s; the actuator integrates them).
    pub intvelocity_rad_per_s: Vec<f64>,
}

impl Command {
    /// A zero command for `n_joints` joints.
    pub fn new(n_joints: usize) -> Self {
        Self {
            torque_nm: vec![0.0; n_joints],
            position_rad: vec![0.0; n_joints],
            velocity_rad_per_s: vec![0.0; n_joints],
            intvelocity_rad_per_s: vec![0.0; n_joints],
        }
    }

    /// Copies `other` into this command (same sizes: no allocation).
    pub fn copy_from(&mut self, other: &Command) {
        self.torque_nm.clone_from(&other.torque_nm);
        self.position_rad.clone_from(&other.position_rad);
        self.velocity_rad_per_s.clone_from(&other.velocity_rad_per_s);
        self.intvelocity_rad_per_s.clone_from(&other.intvelocity_rad_per_s);
    }

    /// The command block of one actuator kind.
    pub fn block(&self, kind: ControlMethod) -> &[f64] {
        match kind {
            ControlMethod::Torque => &self.torque_nm,
            ControlMethod::Position => &self.position_rad,
            ControlMethod::Velocity => &self.velocity_rad_per_s,
            ControlMethod::Intvelocity => &self.intvelocity_rad_per_s,
        }
    }
}

/// A controller: called every physics step with the time and the observation, it writes the
/// actuator commands. Implement this to drive the snake with your own code (see
/// `examples/custom_controller.rs`).
///
/// A controller that needs more than the sensors — link poses and velocities, every contact and
/// its force, actuator and joint forces (everything of thesis table 3) — returns `true` from
/// [`Controller::needs_full_state`] and implements [`Controller::update_with_state`]; the
/// simulation then runs a forward pass before every step so the [`crate::state::Snapshot`] it
/// passes describes the current instant (costs about one extra model evaluation per step).
pub trait Controller {
    /// Called once before the first step (and again if the simulation is reset).
    fn reset(&mut self) {}
    /// Computes the commands for the step starting at `obs.time_secs`. Must not allocate if it
    /// is to keep the step loop fast.
    fn update(&mut self, obs: &Observation, cmd: &mut Command);
    /// Whether [`Controller::update_with_state`] should be called instead of `update`.
    fn needs_full_state(&self) -> bool {
        false
    }
    /// Like `update`, with the full simulator state of this instant (positions, velocities,
    /// contacts, forces) computed with the previous step's commands.
    fn update_with_state(&mut self, obs: &Observation, _state: &crate::state::Snapshot, cmd: &mut Command) {
        self.update(obs, cmd);
    }
    /// Whether the controller looks at the sensors. One that does not (a command held from
    /// outside, as a reinforcement-learning environment's action is) lets the step loop skip
    /// reading and measuring them at every step.
    fn reads_sensors(&self) -> bool {
        true
    }
}

impl<C: Controller + ?Sized> Controller for Box<C> {
    fn reset(&mut self) {
        (**self).reset();
    }
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        (**self).update(obs, cmd);
    }
    fn needs_full_state(&self) -> bool {
        (**self).needs_full_state()
    }
    fn update_with_state(&mut self, obs: &Observation, state: &crate::state::Snapshot, cmd: &mut Command) {
        (**self).update_with_state(obs, state, cmd);
    }
    fn reads_sensors(&self) -> bool {
        (**self).reads_sensors()
    }
}

/// A command set from outside and held: the controller of a reinforcement-learning
/// environment, whose agent sets [`HeldCommand::command`] before stepping. It does not look
/// at the sensors; with `sense_every_step` the step loop still reads them at every step (for
/// contact estimation, whose filters integrate the sensors step by step).
#[derive(Debug, Clone, Default)]
pub struct HeldCommand {
    /// The command sent at every step.
    pub command: Command,
    /// Read (and estimate from) the sensors at every physics step, not only when asked.
    pub sense_every_step: bool,
}

impl Controller for HeldCommand {
    fn update(&mut self, _obs: &Observation, cmd: &mut Command) {
        cmd.copy_from(&self.command);
    }
    fn reads_sensors(&self) -> bool {
        self.sense_every_step
    }
}

/// The controller that `config.control.controller` selects, for `n_joints` joints: the gait
/// ([`TrajectoryController`]), path following ([`PathFollowing`]) or one of the contact laws
/// from the literature ([`FollowTheLeaderReflex`], [`DirectionalAdmittance`],
/// [`JamResolution`]; validation requires the sine wave for them). Path following and the laws
/// shape the sine wave; with another `gait.kind` (none, serpenoid, form closure, …) the gait
/// runs open loop.
pub fn controller_from_config(config: &Config, n_joints: usize) -> Box<dyn Controller> {
    match (config.control.controller, config.gait.kind) {
        (crate::config::ControllerKind::FollowTheLeaderReflex, crate::config::GaitKind::SineWave) => {
            Box::new(FollowTheLeaderReflex::from_config(config, n_joints))
        }
        (crate::config::ControllerKind::DirectionalAdmittance, crate::config::GaitKind::SineWave) => {
            Box::new(DirectionalAdmittance::from_config(config, n_joints))
        }
        (crate::config::ControllerKind::JamResolution, crate::config::GaitKind::SineWave) => {
            Box::new(JamResolution::from_config(config, n_joints))
        }
        (crate::config::ControllerKind::PathFollowing, crate::config::GaitKind::SineWave) => {
            Box::new(PathFollowing::from_config(config, n_joints))
        }
        _ => Box::new(TrajectoryController::from_config(config, n_joints)),
    }
}

/// The joint PID of `method = "torque"`: the `[control]` gains, saturated at
/// `snake.torque_range_nm` over the gear (thesis chapter 8.4). Controllers clone it per joint.
pub fn joint_pid(config: &Config) -> Pid {
    let c = &config.control;
    let [lo, hi] = config.snake.torque_range_nm;
    let gear = c.torque_gear;
    Pid::new(c.pid_kp_nm_per_rad, c.pid_ki_nm_per_rad_s, c.pid_kd_nm_s_per_rad, lo / gear, hi / gear)
}

/// Per joint: whether it turns in the ground plane (yaw). Joint j sits in front of link j+1;
/// alternating axes make every second joint (j = 1, 3, …) a pitch joint.
pub fn yaw_joints(config: &Config, n_joints: usize) -> Vec<bool> {
    (0..n_joints).map(|j| !(config.snake.joint_axes == JointAxes::Alternating && (j + 1).is_multiple_of(2))).collect()
}

/// An angle wrapped to [−π, π) (rad).
pub fn wrap_angle_rad(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

/// The gain k of a first-order low-pass filter over one step, `x += k·(input − x)`:
/// `k = min(Δt/τ, 1)` (the explicit Euler step of `τ·ẋ = input − x`, never overshooting);
/// `τ ≤ 0` means no filter (k = 1).
pub fn low_pass_gain(dt_secs: f64, tau_secs: f64) -> f64 {
    if tau_secs > 0.0 { (dt_secs / tau_secs).clamp(0.0, 1.0) } else { 1.0 }
}

/// The head's yaw as the robot knows it: calibrated from the head's orientation at the first
/// update, then integrated from the head IMU's gyro (z) and wrapped to (−π, π].
#[derive(Debug, Clone, Default)]
pub struct GyroYaw {
    /// The head's yaw (rad).
    pub yaw_rad: f64,
    /// The time of the last update (s).
    pub last_time_secs: f64,
    started: bool,
}

impl GyroYaw {
    /// Forgets the calibration (the next update calibrates again).
    pub fn reset(&mut self) {
        self.started = false;
    }

    /// Integrates the gyro up to `obs.time_secs`; returns the time step since the last update
    /// (s; 0 at the first).
    pub fn update(&mut self, obs: &Observation) -> f64 {
        let t = obs.time_secs;
        if !self.started {
            self.yaw_rad = crate::state::yaw_rad(obs.head_quat);
            self.last_time_secs = t;
            self.started = true;
        }
        let dt = (t - self.last_time_secs).max(0.0);
        self.last_time_secs = t;
        self.yaw_rad = wrap_angle_rad(self.yaw_rad + obs.imu_gyro_rad_per_s.first().map_or(0.0, |g| g[2]) * dt);
        dt
    }
}

/// The snake in the ground plane from what the robot knows: the head's yaw and position (a
/// tracking system) and the encoders. Link i's heading is θ₀ = `head_yaw_rad`, θᵢ = θᵢ₋₁ +
/// qᵢ₋₁ over the yaw joints (our joint angle is the child's heading minus the parent's); link i
/// starts where link i − 1 ends, `link_length_m` behind it, and its centre is half a link
/// further. Writes θᵢ into `heading_rad` (its length is the number of links; missing joint
/// angles count as 0) and returns (the mean heading θ̄ (rad), the centre of mass (x, y) (m)).
pub fn planar_chain(
    head_yaw_rad: f64,
    head_xy_m: [f64; 2],
    joint_angle_rad: &[f64],
    yaw_joint: &[bool],
    link_length_m: f64,
    heading_rad: &mut [f64],
) -> (f64, [f64; 2]) {
    let l = link_length_m;
    let (mut theta, mut o) = (head_yaw_rad, head_xy_m);
    let (mut sum_theta, mut com) = (0.0, [0.0; 2]);
    for (i, heading) in heading_rad.iter_mut().enumerate() {
        if i > 0 {
            o = [o[0] - l * theta.cos(), o[1] - l * theta.sin()];
            if yaw_joint.get(i - 1).copied().unwrap_or(true) {
                theta += joint_angle_rad.get(i - 1).copied().unwrap_or(0.0);
            }
        }
        *heading = theta;
        sum_theta += theta;
        com[0] += o[0] - 0.5 * l * theta.cos();
        com[1] += o[1] - 0.5 * l * theta.sin();
    }
    let n = heading_rad.len().max(1) as f64;
    (sum_theta / n, [com[0] / n, com[1] / n])
}

/// Sends joint `j` to `angle_rad` moving at `velocity_rad_per_s` through the actuator kind
/// `method`: the angle to a position servo, the velocity to a velocity or integrated-velocity
/// servo, and for torque motors the output of `pid` on the errors against the measured joint
/// (`dt_secs` is the PID's step).
#[allow(clippy::too_many_arguments)]
pub fn command_joint(
    method: ControlMethod,
    cmd: &mut Command,
    j: usize,
    angle_rad: f64,
    velocity_rad_per_s: f64,
    obs: &Observation,
    pid: &mut Pid,
    dt_secs: f64,
) {
    match method {
        ControlMethod::Position => cmd.position_rad[j] = angle_rad,
        ControlMethod::Velocity => cmd.velocity_rad_per_s[j] = velocity_rad_per_s,
        ControlMethod::Intvelocity => cmd.intvelocity_rad_per_s[j] = velocity_rad_per_s,
        ControlMethod::Torque => {
            let error = angle_rad - obs.joint_angle_rad[j];
            let error_rate = velocity_rad_per_s - obs.joint_velocity_rad_per_s[j];
            cmd.torque_nm[j] = pid.update(error, error_rate, dt_secs);
        }
    }
}

/// The built-in controller: follows a joint trajectory with the configured actuator kind.
/// `position` sends the target angle, `velocity` and `intvelocity` the target velocity, and
/// `torque` runs a PID on the angle error per joint (thesis chapter 8.4), saturated at the
/// torque range.
pub struct TrajectoryController {
    trajectory: Box<dyn JointTrajectory>,
    method: ControlMethod,
    pids: Vec<Pid>,
    target_rad: Vec<f64>,
    target_velocity_rad_per_s: Vec<f64>,
    dt_secs: f64,
}

impl TrajectoryController {
    /// Builds the controller that `config` describes for `n_joints` joints.
    pub fn from_config(config: &Config, n_joints: usize) -> Self {
        let pids = vec![joint_pid(config); n_joints];
        Self::new(trajectory_from_config(config), config.control.method, pids, config.general.timestep_secs)
    }

    /// A controller from its parts: one PID per joint (used only with `method = torque`).
    pub fn new(trajectory: Box<dyn JointTrajectory>, method: ControlMethod, pids: Vec<Pid>, dt_secs: f64) -> Self {
        let n = pids.len();
        Self { trajectory, method, pids, target_rad: vec![0.0; n], target_velocity_rad_per_s: vec![0.0; n], dt_secs }
    }
}

impl Controller for TrajectoryController {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
    }

    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        self.trajectory.targets(obs.time_secs, &mut self.target_rad, &mut self.target_velocity_rad_per_s);
        match self.method {
            ControlMethod::Position => cmd.position_rad.copy_from_slice(&self.target_rad),
            ControlMethod::Velocity => cmd.velocity_rad_per_s.copy_from_slice(&self.target_velocity_rad_per_s),
            ControlMethod::Intvelocity => cmd.intvelocity_rad_per_s.copy_from_slice(&self.target_velocity_rad_per_s),
            ControlMethod::Torque => {
                for (j, pid) in self.pids.iter_mut().enumerate() {
                    let error = self.target_rad[j] - obs.joint_angle_rad[j];
                    let error_rate = self.target_velocity_rad_per_s[j] - obs.joint_velocity_rad_per_s[j];
                    cmd.torque_nm[j] = pid.update(error, error_rate, self.dt_secs);
                }
            }
        }
    }
}

/// Where a contact-feeling controller (a contact law) gets its contacts: the step
/// loop's estimates in the observation, or, for comparison, the simulator's truth, which needs
/// the full state (`Controller::update_with_state`): `ContactSource::True` the obstacle forces
/// alone, `ContactSource::TrueWithSelf` the obstacles' and the other links' (self-contact)
/// forces together as one obstacle force ([`crate::state::ContactEstimates::fill_from_truth`]).
#[derive(Debug, Clone)]
pub struct ContactFeed {
    /// Where the contacts come from.
    pub source: crate::config::ContactSource,
    /// With a true source: a link touches a peg when the true horizontal obstacle force reaches
    /// this (N; the estimator's detection threshold).
    pub true_threshold_n: f64,
    /// The contacts feed the law from this time on (s): the end of the gait's ramp-in,
    /// `gait.ramp_secs` ([`feel`]).
    pub from_secs: f64,
    /// The true contacts, filled each step (no allocation after construction).
    truth: crate::state::ContactEstimates,
}

impl ContactFeed {
    /// The feed of `source` for `n_links` links, with `config`'s detection threshold.
    pub fn new(config: &Config, source: crate::config::ContactSource, n_links: usize) -> Self {
        Self {
            source,
            true_threshold_n: config.estimation.detection_threshold_n,
            from_secs: config.gait.ramp_secs,
            truth: crate::state::ContactEstimates::new(n_links),
        }
    }

    /// Whether the controller needs the simulator's state (the true contacts).
    pub fn needs_full_state(&self) -> bool {
        self.source != crate::config::ContactSource::Estimated
    }
}

/// One update of the contact-feeling controller `ctl` (its feed reached through `feed`): calls
/// `step` with this instant's contacts — the observation's estimates; the truth of `state` with
/// a true source; nothing (inactive estimates) with a true source and no state, and with any
/// source during the gait's ramp-in (before [`ContactFeed::from_secs`]).
///
/// Why not during the ramp-in: while the wave's amplitude grows from 0 on stiff servos the links
/// lift and land (SPEC: landings of 7–16 × m·g in a reference engine too), and the floor's
/// forces are then not the steady Coulomb friction of the estimator's floor share: on a bare
/// floor with the OAL benchmark's base gait the estimates flag 0.01–1.9 % of each link's steps
/// as obstacle contacts (up to 80 N), every one of them in the first second, none after it
/// (`tests/it/oal_bench.rs`, `probe_bare_floor_flags_per_link`). A law that reacted to them
/// would bend a body that touched nothing, and its follow-the-leader offsets would carry that
/// bend down the whole body. The same rule holds for the true contacts, so the estimated and the
/// true feeds are compared like with like.
pub(crate) fn feel<C>(
    ctl: &mut C,
    feed: fn(&mut C) -> &mut ContactFeed,
    step: fn(&mut C, &Observation, &crate::state::ContactEstimates, &mut Command),
    obs: &Observation,
    state: Option<&crate::state::Snapshot>,
    cmd: &mut Command,
) {
    use crate::config::ContactSource;
    let f = feed(ctl);
    if obs.time_secs < f.from_secs {
        step(ctl, obs, &crate::state::ContactEstimates::default(), cmd);
        return;
    }
    match (f.source, state) {
        (ContactSource::Estimated, _) => step(ctl, obs, &obs.contacts, cmd),
        (ContactSource::True | ContactSource::TrueWithSelf, None) => {
            step(ctl, obs, &crate::state::ContactEstimates::default(), cmd);
        }
        (source @ (ContactSource::True | ContactSource::TrueWithSelf), Some(state)) => {
            let threshold_n = f.true_threshold_n;
            let mut truth = std::mem::take(&mut f.truth);
            truth.fill_from_truth(state, threshold_n, source == ContactSource::TrueWithSelf);
            step(ctl, obs, &truth, cmd);
            feed(ctl).truth = truth;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn low_pass_gain_is_dt_over_tau_capped_at_one() {
        assert!((low_pass_gain(0.002, 0.5) - 0.004).abs() < 1e-15);
        // A step longer than τ, or no filter, passes the input through.
        assert_eq!(low_pass_gain(1.0, 0.5), 1.0);
        assert_eq!(low_pass_gain(0.002, 0.0), 1.0);
        assert_eq!(low_pass_gain(0.0, 0.0), 1.0);
        // The filtered value approaches a constant input as 1 − (1 − k)^n.
        let (mut x, k) = (0.0, low_pass_gain(0.01, 0.1));
        for _ in 0..10 {
            x += k * (1.0 - x);
        }
        assert!((x - (1.0 - 0.9f64.powi(10))).abs() < 1e-12);
    }

    #[test]
    fn position_method_sends_trajectory_angles() {
        let mut config = Config::default();
        config.gait.ramp_secs = 0.0;
        config.control.method = ControlMethod::Position;
        let mut ctl = TrajectoryController::from_config(&config, 3);
        let mut obs = Observation::new(4, 3);
        obs.time_secs = 0.3;
        let mut cmd = Command::new(3);
        ctl.update(&obs, &mut cmd);
        let w = &config.gait.sine_wave;
        for (j, value) in cmd.position_rad.iter().enumerate() {
            let expected = w.amplitude_deg.to_radians()
                * (std::f64::consts::TAU * w.frequency_hz * 0.3 - j as f64 * w.phase_lag_deg.to_radians()).sin();
            assert!((value - expected).abs() < 1e-12);
        }
        assert!(cmd.torque_nm.iter().all(|t| *t == 0.0));
    }

    #[test]
    fn torque_method_pushes_toward_target_and_saturates() {
        let mut config = Config::default();
        config.gait.kind = crate::config::GaitKind::None;
        config.control.method = ControlMethod::Torque;
        config.control.pid_kp_nm_per_rad = 100.0;
        let mut ctl = TrajectoryController::from_config(&config, 2);
        let mut obs = Observation::new(3, 2);
        obs.joint_angle_rad = vec![0.5, -0.001];
        let mut cmd = Command::new(2);
        ctl.update(&obs, &mut cmd);
        assert_eq!(cmd.torque_nm[0], config.snake.torque_range_nm[0]);
        assert!(cmd.torque_nm[1] > 0.0 && cmd.torque_nm[1] < config.snake.torque_range_nm[1]);
    }
}

//! Runaway-energy guard of the step loop (`[safety]` in the config).
//!
//! Criterion: every `safety.check_every_n_steps` steps the kinetic energy of everything that
//! moves in the model, `E = ½ q̇ᵀ M(q) q̇` (MuJoCo's `mj_energyVel`, with the mass matrix of the
//! step's last model evaluation), is divided by the robot's mass; the run stops when it exceeds
//! `safety.max_kinetic_energy_j_per_kg`. Per kilogram, so that one bound fits a 2-link toy and a
//! 200-link snake alike: E/m = ½ v_rms², and the default 5000 J/kg is an RMS speed of 100 m/s.
//!
//! Why a bound is sound: the built-in actuators are limited to `snake.torque_range_nm`, gravity
//! is bounded and contacts and damping dissipate, so the energy a run can gain is bounded by
//! what the actuators can do; an energy growing past any physical value means the integration
//! is unstable (typically an explicit integrator with a stiff servo or contact at too large a
//! timestep), usually many steps before the state becomes NaN or MuJoCo resets it.
//!
//! Cost: one mass-matrix product (`mj_mulM`, O(nv · depth), MuJoCo's stack, no heap
//! allocation) every `check_every_n_steps` steps; nothing is formatted unless the guard trips.

use super::{SimError, World};
use crate::config::Config;

/// The energy guard of one simulation.
#[derive(Debug, Clone, Copy)]
pub struct EnergyGuard {
    /// Largest allowed kinetic energy (J); infinite when the check is off.
    limit_j: f64,
    /// The configured bound per kilogram (J/kg), for the message.
    limit_j_per_kg: f64,
    /// Robot mass (kg).
    mass_kg: f64,
    /// Check every this many steps.
    every: u64,
}

impl EnergyGuard {
    /// The guard that `config.safety` describes for `world`'s robot.
    pub fn new(config: &Config, world: &World) -> Self {
        let s = &config.safety;
        let mass_kg = world.index.robot_mass_kg;
        let off = s.max_kinetic_energy_j_per_kg <= 0.0 || !s.max_kinetic_energy_j_per_kg.is_finite() || mass_kg <= 0.0;
        Self {
            limit_j: if off { f64::INFINITY } else { s.max_kinetic_energy_j_per_kg * mass_kg },
            limit_j_per_kg: s.max_kinetic_energy_j_per_kg,
            mass_kg,
            every: s.check_every_n_steps.max(1),
        }
    }

    /// Whether the guard checks anything.
    pub fn enabled(&self) -> bool {
        self.limit_j.is_finite()
    }

    /// Checks after step number `step` (1-based), which reached simulated time `time_secs`.
    #[inline]
    pub fn check(&self, world: &mut World, step: u64, time_secs: f64) -> Result<(), SimError> {
        if !self.enabled() || !step.is_multiple_of(self.every) {
            return Ok(());
        }
        let energy_j = world.kinetic_energy_j();
        // A NaN energy trips the guard too.
        if energy_j > self.limit_j || energy_j.is_nan() {
            return Err(SimError::Diverged {
                time_secs,
                step,
                what: format!(
                    "runaway energy: kinetic energy {energy_j:.6e} J = {:.6e} J/kg of robot ({:.4} kg) exceeds \
                     safety.max_kinetic_energy_j_per_kg = {} J/kg (an unstable integration: try a smaller \
                     general.timestep_secs, the RK4 or implicitfast integrator, or softer gains)",
                    energy_j / self.mass_kg,
                    self.mass_kg,
                    self.limit_j_per_kg
                ),
            });
        }
        Ok(())
    }
}

impl World {
    /// Kinetic energy of everything that moves, ½ q̇ᵀ M q̇ (J), with the mass matrix of the last
    /// model evaluation (no allocation).
    pub fn kinetic_energy_j(&mut self) -> f64 {
        self.data.energy_vel();
        self.data.energy()[1]
    }
}

/// Checks that a user's robot has what the configured gait needs: with `gait.kind` other than
/// `"none"` the gait drives every hinge and slide joint through the actuator acting on it, so
/// the robot needs at least one such joint and an actuator on each of them. Returns the problem,
/// naming the joint (the caller adds the file).
pub(crate) fn check_robot_actuators(config: &Config, index: &super::Index) -> Result<(), String> {
    use crate::config::GaitKind;
    if config.gait.kind == GaitKind::None {
        return Ok(());
    }
    let gait =
        toml::Value::try_from(config.gait.kind).map_or_else(|_| format!("{:?}", config.gait.kind), |v| v.to_string());
    let element = match config.control.method {
        crate::config::ControlMethod::Torque => "<motor>",
        crate::config::ControlMethod::Position => "<position>",
        crate::config::ControlMethod::Velocity => "<velocity>",
        crate::config::ControlMethod::Intvelocity => "<intvelocity>",
    };
    let fix = format!(
        "add a {element} actuator (or an equivalent <general> one) with joint=\"…\" for it (control.method = \"{}\"), \
         set robot.position_servos = true (a position servo on every joint without an actuator, as a URDF needs: it \
         has no actuators), or run with --set gait.kind=none",
        config.control.method.name()
    );
    if index.joints.is_empty() {
        return Err(format!(
            "the robot has no hinge or slide joint, but gait.kind = {gait} needs actuated joints to move; {fix}"
        ));
    }
    match index.joints.iter().find(|j| j.actuators.iter().all(Option::is_none)) {
        Some(joint) => Err(format!(
            "joint `{}` has no actuator, but gait.kind = {gait} drives every hinge and slide joint; {fix}",
            joint.name
        )),
        None => Ok(()),
    }
}

//! Checks of the floor-friction keys (`physics.floor_friction`,
//! `physics.floor_stick_time_constant_secs`), kept apart from `validate.rs`.

use super::validate::fmt_f;
use super::{Config, ConfigError, FloorFriction, GroundModel};

impl Config {
    /// `physics.floor_stick_time_constant_secs` finite and > 0; with `"stick_slip"` in use (any
    /// ground model but `"viscous"`), at least 5 timesteps (the stick spring–damper is applied as
    /// a force held over each step: at 3 timesteps a resting snake creeps, 5.3 mm in 20 s), and no torsional or
    /// rolling ground friction (SimSerpent's law has none; a link's two contact points resist
    /// turning in place).
    pub(super) fn validate_floor_friction(&self) -> Result<(), ConfigError> {
        let p = &self.physics;
        let key = "physics.floor_stick_time_constant_secs";
        let tau = p.floor_stick_time_constant_secs;
        if !tau.is_finite() || tau <= 0.0 {
            return Err(ConfigError::invalid(key, fmt_f(tau), "must be a finite number greater than 0"));
        }
        let own = p.floor_friction == FloorFriction::StickSlip && self.ground.model != GroundModel::Viscous;
        if !own {
            return Ok(());
        }
        let min = 5.0 * self.general.timestep_secs;
        // (A relative hair of tolerance: 5 x 0.001 must accept 0.005 whatever the rounding.)
        if tau < min * (1.0 - 1e-9) {
            return Err(ConfigError::invalid(
                key,
                fmt_f(tau),
                format!(
                    "must be at least 5 x general.timestep_secs = {} with physics.floor_friction = \"stick_slip\" (the \
                     stick spring-damper is applied once per step; at 3 timesteps a resting snake already creeps)",
                    fmt_f(min)
                ),
            ));
        }
        let g = &self.snake.ground_friction;
        if g[1] != 0.0 || g[2] != 0.0 {
            return Err(ConfigError::invalid(
                "snake.ground_friction",
                super::validate::fmt_a(g),
                "torsional and rolling coefficients must be 0 with physics.floor_friction = \"stick_slip\" \
                 (SimSerpent's floor friction has only sliding friction)",
            ));
        }
        Ok(())
    }
}

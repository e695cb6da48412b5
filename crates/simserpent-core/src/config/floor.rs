//! The floor-friction and environment-contact keys (`physics.floor_friction`,
//! `physics.floor_stick_time_constant_secs`, `physics.environment_contact_*`): the
//! `"auto"`-or-seconds values and their checks, kept apart from `validate.rs`.

use super::text::fmt_f;
use super::{Config, ConfigError, EnvironmentContactSolve, FloorFriction, GroundModel};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// The smallest stick time constant `"auto"` gives (s).
pub const AUTO_STICK_TIME_CONSTANT_MIN_SECS: f64 = 0.005;
/// `"auto"` gives at least this many timesteps, as does the check of an explicit value: the stick
/// spring–damper is applied as a force held over each step (explicit), and at 3 timesteps a
/// resting snake already creeps (5.3 mm in 20 s).
pub const STICK_TIME_CONSTANT_MIN_TIMESTEPS: f64 = 5.0;
/// The most energy (J) a floor slot's stick spring gives back in one step by springing back
/// along its contact point's motion (`physics.floor_friction = "stick_slip"`): enough for a stuck
/// link's own small oscillation about its anchor (holding on a slope), too little to drive a
/// coasting body. The contact estimator's floor model applies the same rule.
pub const STICK_RELEASE_J: f64 = 1e-7;
/// The smallest environment contact time constant `"auto"` gives (s): a link at 5 m/s stops
/// within 5 mm (user guide, "Floor contact").
pub const AUTO_ENVIRONMENT_CONTACT_TIME_CONSTANT_MIN_SECS: f64 = 0.002;
/// MuJoCo's rule: a contact time constant spans at least 2 timesteps.
pub const CONTACT_TIME_CONSTANT_MIN_TIMESTEPS: f64 = 2.0;

/// A time in seconds, or `"auto"`: a value derived from the timestep (each key says how).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AutoSecs {
    /// Derived from `general.timestep_secs`.
    Auto,
    /// This many seconds.
    Secs(f64),
}

/// `physics.floor_stick_time_constant_secs`.
pub type StickTimeConstant = AutoSecs;

impl AutoSecs {
    /// The value in seconds; `"auto"` is max(`min_secs`, `min_timesteps` × `timestep_secs`).
    pub fn secs_or(self, min_secs: f64, min_timesteps: f64, timestep_secs: f64) -> f64 {
        match self {
            Self::Auto => min_secs.max(min_timesteps * timestep_secs),
            Self::Secs(s) => s,
        }
    }
}

impl Serialize for AutoSecs {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Auto => s.serialize_str("auto"),
            Self::Secs(x) => s.serialize_f64(*x),
        }
    }
}

impl<'de> Deserialize<'de> for AutoSecs {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = AutoSecs;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a time in seconds (a number) or \"auto\"")
            }
            fn visit_f64<E: serde::de::Error>(self, x: f64) -> Result<Self::Value, E> {
                Ok(AutoSecs::Secs(x))
            }
            fn visit_i64<E: serde::de::Error>(self, x: i64) -> Result<Self::Value, E> {
                Ok(AutoSecs::Secs(x as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, x: u64) -> Result<Self::Value, E> {
                Ok(AutoSecs::Secs(x as f64))
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<Self::Value, E> {
                if s == "auto" {
                    Ok(AutoSecs::Auto)
                } else {
                    Err(E::invalid_value(serde::de::Unexpected::Str(s), &self))
                }
            }
        }
        d.deserialize_any(V)
    }
}

impl Config {
    /// The stick time constant of SimSerpent's floor friction in seconds
    /// (`physics.floor_stick_time_constant_secs`; `"auto"`: max(5 ms, 5 timesteps)).
    pub fn floor_stick_time_constant_secs(&self) -> f64 {
        self.physics.floor_stick_time_constant_secs.secs_or(
            AUTO_STICK_TIME_CONSTANT_MIN_SECS,
            STICK_TIME_CONSTANT_MIN_TIMESTEPS,
            self.general.timestep_secs,
        )
    }

    /// The time constant of the link–obstacle and link–ground contacts in seconds
    /// (`physics.environment_contact_time_constant_secs`; `"auto"`: max(2 ms, 2 timesteps)).
    pub fn environment_contact_time_constant_secs(&self) -> f64 {
        self.physics.environment_contact_time_constant_secs.secs_or(
            AUTO_ENVIRONMENT_CONTACT_TIME_CONSTANT_MIN_SECS,
            CONTACT_TIME_CONSTANT_MIN_TIMESTEPS,
            self.general.timestep_secs,
        )
    }

    /// `physics.environment_contact_*`: `"auto"` or finite, > 0 and at least 2 timesteps (MuJoCo's
    /// rule), and a damping ratio finite and > 0.
    pub(super) fn validate_environment_contact(&self) -> Result<(), ConfigError> {
        let p = &self.physics;
        let key = "physics.environment_contact_time_constant_secs";
        if let AutoSecs::Secs(tau) = p.environment_contact_time_constant_secs {
            if !tau.is_finite() || tau <= 0.0 {
                return Err(ConfigError::invalid(
                    key,
                    fmt_f(tau),
                    "must be \"auto\" or a finite number of seconds greater than 0",
                ));
            }
            let min = CONTACT_TIME_CONSTANT_MIN_TIMESTEPS * self.general.timestep_secs;
            if tau < min * (1.0 - 1e-9) {
                return Err(ConfigError::invalid(
                    key,
                    fmt_f(tau),
                    format!(
                        "must be at least 2 x general.timestep_secs = {} (MuJoCo's rule for stable contacts), or \
                         \"auto\" (max(0.002, 2 x general.timestep_secs))",
                        fmt_f(min)
                    ),
                ));
            }
        }
        let zeta = p.environment_contact_damping_ratio;
        if !zeta.is_finite() || zeta <= 0.0 {
            return Err(ConfigError::invalid(
                "physics.environment_contact_damping_ratio",
                fmt_f(zeta),
                "must be a finite number greater than 0 (1 = critically damped, below 1 the contact bounces)",
            ));
        }
        let e = p.contact_restitution;
        if !e.is_finite() || e <= 0.0 || e > 1.0 {
            return Err(ConfigError::invalid(
                "physics.contact_restitution",
                fmt_f(e),
                "must be a number greater than 0 and at most 1 (rebound speed / impact speed; 1 = elastic)",
            ));
        }
        Ok(())
    }
}

impl Config {
    /// `physics.floor_stick_time_constant_secs` `"auto"` or finite and > 0; with `"stick_slip"` in
    /// use (any ground model but `"viscous"`), an explicit value at least 5 timesteps (the stick spring–damper is applied as
    /// a force held over each step: at 3 timesteps a resting snake creeps, 5.3 mm in 20 s), and no torsional or
    /// rolling ground friction (SimSerpent's law has none; a link's two contact points resist
    /// turning in place).
    pub(super) fn validate_floor_friction(&self) -> Result<(), ConfigError> {
        let p = &self.physics;
        let key = "physics.floor_stick_time_constant_secs";
        let own = p.floor_friction == FloorFriction::StickSlip && self.ground.model != GroundModel::Viscous;
        if p.environment_contact_solve == EnvironmentContactSolve::WholeBody && !own {
            return Err(ConfigError::invalid(
                "physics.environment_contact_solve",
                "\"whole_body\"",
                format!(
                    "\"whole_body\" needs SimSerpent's own contact law: physics.floor_friction = \"stick_slip\" \
                     and a ground.model other than \"viscous\" (here {:?} and {:?}); use \"per_link\" otherwise",
                    p.floor_friction, self.ground.model
                ),
            ));
        }
        let StickTimeConstant::Secs(tau) = p.floor_stick_time_constant_secs else {
            return if own { self.validate_no_torsional_ground_friction() } else { Ok(()) };
        };
        if !tau.is_finite() || tau <= 0.0 {
            return Err(ConfigError::invalid(
                key,
                fmt_f(tau),
                "must be \"auto\" or a finite number of seconds greater than 0",
            ));
        }
        if !own {
            return Ok(());
        }
        let min = STICK_TIME_CONSTANT_MIN_TIMESTEPS * self.general.timestep_secs;
        // (A relative hair of tolerance: 5 x 0.001 must accept 0.005 whatever the rounding.)
        if tau < min * (1.0 - 1e-9) {
            return Err(ConfigError::invalid(
                key,
                fmt_f(tau),
                format!(
                    "must be at least 5 x general.timestep_secs = {} with physics.floor_friction = \"stick_slip\" (the \
                     stick spring-damper is applied once per step; at 3 timesteps a resting snake already creeps), \
                     or \"auto\" (max(0.005, 5 x general.timestep_secs))",
                    fmt_f(min)
                ),
            ));
        }
        self.validate_no_torsional_ground_friction()
    }

    /// With `"stick_slip"` in use: no torsional or rolling ground or obstacle friction.
    fn validate_no_torsional_ground_friction(&self) -> Result<(), ConfigError> {
        let g = &self.snake.ground_friction;
        if g[1] != 0.0 || g[2] != 0.0 {
            return Err(ConfigError::invalid(
                "snake.ground_friction",
                super::text::fmt_a(g),
                "torsional and rolling coefficients must be 0 with physics.floor_friction = \"stick_slip\" \
                 (SimSerpent's floor friction has only sliding friction)",
            ));
        }
        let o = &self.terrain.obstacle_friction;
        if o[1] != 0.0 || o[2] != 0.0 {
            return Err(ConfigError::invalid(
                "terrain.obstacle_friction",
                super::text::fmt_a(o),
                "torsional and rolling coefficients must be 0 with physics.floor_friction = \"stick_slip\" \
                 (SimSerpent applies the link-obstacle friction too, and it has only sliding friction)",
            ));
        }
        Ok(())
    }
}

//! SimSerpent's pure core: everything that does not need the engine or the file system beyond
//! the config and the terrain sources it names.
//!
//! - [`config`]: parse, merge and validate configurations (key paths in every error);
//! - [`contact_law`]: the normal force of one contact point and its restitution;
//! - [`model`]: generate the MJCF text of the snake and its terrain;
//! - [`control`]: the [`control::Controller`] trait, observations, commands, gaits, PID;
//! - [`estimation`]: contact-force estimation from joint force/torque sensors and IMUs;
//! - [`state`]: the plain state of one instant ([`state::Snapshot`], contact rows) and the
//!   physics summaries computed from it (centre of mass, heading, actuator power, peak force).
//!
//! This crate does not depend on MuJoCo: the compiler, not a grep, keeps it pure. The engine
//! lives in the `simserpent` crate (`simserpent::sim`), which re-exports these modules under the
//! same paths.
pub mod config;
pub mod contact_law;
pub mod control;
pub mod estimation;
pub mod model;
pub mod state;

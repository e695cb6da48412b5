//! SimSerpent: a physics-based snake-robot simulator on MuJoCo 3.17.
//!
//! Map (see ARCHITECTURE.md):
//! - pure core, no MuJoCo and no I/O: [`config`], [`model`] (MJCF generation), [`control`],
//!   [`estimation`] (contact forces from joint force/torque sensors);
//! - the engine: [`sim`] (the only module that calls MuJoCo);
//! - I/O: [`record`] (run folder, manifest, tables), [`run`] (one whole run), [`bench`],
//!   [`sweep`] (parallel parameter sweeps);
//! - [`env`]: the reinforcement-learning environment core (actions in, observations and
//!   rewards out) behind the Python package's Gymnasium environments;
//! - [`interrupt`]: the clean stop on SIGINT/SIGTERM;
//! - the command line lives in `src/main.rs`.
pub mod bench;
pub mod config;
pub mod control;
pub mod env;
pub mod estimation;
pub mod experiments;
pub mod interrupt;
pub mod model;
pub mod plot;
pub mod record;
pub mod render;
pub mod run;
pub mod sim;
pub mod sweep;

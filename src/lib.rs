//! SimSerpent: a physics-based snake-robot simulator on MuJoCo 3.17.
//!
//! Map (see ARCHITECTURE.md):
//! - the pure core, the crate `simserpent-core` (no MuJoCo, no I/O; re-exported here under the
//!   same paths): [`config`], [`model`] (MJCF generation), [`control`], [`estimation`] (contact
//!   forces from joint force/torque sensors), [`state`] (the plain state of an instant and the
//!   physics summaries);
//! - the engine: [`sim`] (the only module that steps or changes MuJoCo's state, and the only
//!   step loop; [`render`] draws with MuJoCo's renderer on its own copies of the state);
//! - I/O: [`record`] (run folder, manifest, tables), [`run`] (one whole run), [`bench`],
//!   [`sweep`] (parallel parameter sweeps), [`render`], [`plot`], [`experiments`];
//! - [`env`]: the reinforcement-learning environment core (actions in, observations and
//!   rewards out) behind the Python package's Gymnasium environments;
//! - [`interrupt`]: the clean stop on SIGINT/SIGTERM;
//! - the command line lives in `src/main.rs`.
pub use simserpent_core::{config, contact_law, control, estimation, model, state};

pub mod bench;
pub mod cpu_time;
#[doc(hidden)]
pub mod docgen;
pub mod env;
pub mod estimate;
pub mod experiments;
pub mod files;
pub mod interrupt;
pub mod plot;
pub mod record;
pub mod render;
pub mod ros2;
pub mod run;
pub mod setup_progress;
pub mod sim;
pub mod study;
pub mod sweep;

/// The most worker threads `sweep`, `experiment` and `study` start (`--threads`): runs are
/// CPU-bound, so more threads than cores only cost memory and start-up time; 256 covers the
/// largest machines while a mistyped `--threads 100000` is refused at once instead of starting
/// thousands of threads. The same bound on every machine, so a command line that works on one works
/// on all.
pub const MAX_THREADS: usize = 256;

/// [`MAX_THREADS`] as an error message for `what` (the option or field), or `None` when
/// `threads` is within it.
pub fn threads_beyond_cap(what: &str, threads: usize) -> Option<String> {
    (threads > MAX_THREADS).then(|| {
        format!("{what} {threads}: at most {MAX_THREADS} worker threads (0 = one per core); runs are CPU-bound")
    })
}

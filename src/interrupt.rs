//! Clean stop on SIGINT (Ctrl-C) and SIGTERM: one policy for every long-running command.
//!
//! [`install_handler`] (called by the binary for `run`, `sweep`, `experiment`, `study`,
//! `estimate`, `bench`, `plot` and `render`) makes the first SIGINT or SIGTERM only raise a flag
//! (and say so on stderr), which each stage acts on:
//! - set-up (config, model generation, the model compile — one MuJoCo call that may take many
//!   seconds and cannot be cut short): checked when set-up is done, before the run folder is
//!   created ([`crate::run::RunError::InterruptedSetUp`]): no run folder is left;
//! - every step loop looks at it every [`CHECK_EVERY_N_STEPS`] steps and then stops (runs:
//!   [`crate::run`]; runs in memory — the study, in-memory experiments, the benchmark — through
//!   [`Poll`]): a run's tables are flushed (whole rows only), its manifest is marked `incomplete`
//!   with the reason;
//! - experiments, studies, sweeps and the estimator look at it between and inside their sub-runs
//!   ([`check`]) and start nothing new;
//! - plotting looks at it before each file: the run's manifest stays `complete` (the run is) and
//!   its `plots` says `interrupted`.
//!
//! The command then exits with code 130. A second signal while the first is being handled ends
//! the process at once (exit code 130; during set-up that is the way to leave a long model
//! compile; during a run the tables may then end in a partial row). SIGTERM is treated exactly
//! like SIGINT. A handler also replaces an inherited "ignore SIGINT" (a job started with `&` by a
//! non-interactive shell), so such a job stops on SIGINT like one in the foreground.
//!
//! Library users who do not install the handler keep the default behaviour of the signals; they
//! may also stop runs themselves with [`request`] (for example from a GUI thread).

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// The step loop looks at the flag once every this many steps (an atomic load: negligible).
pub const CHECK_EVERY_N_STEPS: u64 = 64;

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Installs the SIGINT/SIGTERM handler for this process (replacing one installed before).
///
/// # Errors
/// The operating system refused to install it.
pub fn install_handler() -> Result<(), ctrlc::Error> {
    ctrlc::set_handler(|| {
        if REQUESTED.swap(true, Ordering::SeqCst) {
            // Second signal: the user insists.
            std::process::exit(130);
        }
        // This runs on the handler's own thread, not in signal context: writing is safe. A closed
        // stderr is ignored.
        let _ = writeln!(
            std::io::stderr().lock(),
            "simserpent: stopping cleanly (a model compile or a plot in progress finishes first); signal again to quit at once"
        );
    })
}

/// Whether a stop has been requested (by a signal or by [`request`]).
#[inline]
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// Requests every running step loop of this process to stop, as a signal would.
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Clears a request, so that later runs of this process run again.
pub fn clear() {
    REQUESTED.store(false, Ordering::SeqCst);
}

/// `Err(SimError::Interrupted)` naming `at` (e.g. "before case X") when a stop was requested.
///
/// # Errors
/// A stop was requested.
pub fn check(at: impl FnOnce() -> String) -> Result<(), crate::sim::SimError> {
    if requested() { Err(crate::sim::SimError::Interrupted { at: at() }) } else { Ok(()) }
}

/// An observer that stops a step loop run in memory (no run folder) when a stop was requested,
/// with [`crate::sim::SimError::Interrupted`]; it looks at the flag every
/// [`CHECK_EVERY_N_STEPS`] instants.
#[derive(Debug, Clone, Default)]
pub struct Poll {
    /// What the loop runs, for the error ("case X").
    pub what: String,
}

impl Poll {
    /// A poll for the loop of `what` ("case X", "setting Y").
    pub fn new(what: impl Into<String>) -> Self {
        Self { what: what.into() }
    }
}

impl<E: From<crate::sim::SimError>> crate::sim::Observer<E> for Poll {
    fn on_step(&mut self, view: &crate::sim::StepView<'_>) -> Result<(), E> {
        if view.k.is_multiple_of(CHECK_EVERY_N_STEPS) && !view.is_last() && requested() {
            return Err(E::from(crate::sim::SimError::Interrupted {
                at: format!("at t = {:.6} s (step {}) of {}", view.time_secs(), view.k, self.what),
            }));
        }
        Ok(())
    }
}

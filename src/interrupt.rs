//! Clean stop on SIGINT (Ctrl-C) and SIGTERM.
//!
//! [`install_handler`] (called by the `simserpent run` and `sweep` commands) makes the first
//! SIGINT or SIGTERM only raise a flag (and say so on stderr), which each stage of a run acts on:
//! - set-up (config, model generation, the model compile — one MuJoCo call that may take many
//!   seconds and cannot be cut short): checked when set-up is done, before the run folder is
//!   created ([`crate::run::RunError::InterruptedSetUp`]): no run folder is left;
//! - the step loop ([`crate::run`]) looks at it every [`CHECK_EVERY_N_STEPS`] steps and then
//!   stops: the tables are flushed (whole rows only), the manifest is marked `incomplete` with
//!   the reason;
//! - plotting (`general.plot = true`) looks at it before each file: the manifest stays
//!   `complete` (the run is) and its `plots` says `interrupted`.
//!
//! The command then exits with code 130. A second signal while the first is being handled ends
//! the process at once (exit code 130; during set-up that is the way to leave a long model
//! compile; during the run the tables may then end in a partial row).
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

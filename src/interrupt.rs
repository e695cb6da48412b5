//! Clean stop on SIGINT (Ctrl-C) and SIGTERM.
//!
//! [`install_handler`] (called by the `simserpent run` command) makes the first SIGINT or
//! SIGTERM only raise a flag; the step loop ([`crate::run`]) looks at it every
//! [`CHECK_EVERY_N_STEPS`] steps and then stops: the tables are flushed (whole rows only), the
//! manifest is marked `incomplete` with the reason, and the command exits with code 130. A second
//! signal while the first is being handled ends the process at once (exit code 130, the tables
//! may then end in a partial row).
//!
//! Library users who do not install the handler keep the default behaviour of the signals; they
//! may also stop runs themselves with [`request`] (for example from a GUI thread).

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

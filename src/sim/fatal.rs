//! MuJoCo's fatal errors (`mju_error`: a model whose `<size memory>` is too small for its
//! contacts, a stack overflow in the solver, …). MuJoCo cannot go on after one: its handler must
//! not return (the C code would continue in a broken state) and a Rust panic may not unwind
//! through MuJoCo's C frames. So the handler that [`install`] registers ends the process itself,
//! after it has ended what the thread was doing the way SimSerpent ends it for any other error:
//!
//! - during set-up ([`set_up`]: loading, compiling and first evaluating a model): the message
//!   names the file (the robot file, or the config), exit code 2, no run folder, and no scratch
//!   folder ([`super::scratch_dir`]) is left in the temp dir;
//! - during a run ([`during_run`], registered by the run): the run's own finisher closes every
//!   table with the rows of the last recorded instant and writes the manifest `failed`, naming
//!   the error and the simulated time of the step ([`at_step`]); exit code 1, like a divergence;
//! - elsewhere: the message, exit code 1.
//!
//! Every other MuJoCo message (warnings, info) goes to the `log` crate (target `mujoco`), as
//! `mujoco-rs`' own hook sends it.

use mujoco_rs::prelude::{MjLogMessage, MjtLogLevel};
use std::cell::{Cell, RefCell};
use std::path::PathBuf;
use std::sync::Mutex;

/// The most characters of MuJoCo's message kept in an error (its messages are one line).
const MAX_MESSAGE_CHARS: usize = 2000;

/// Ends a run after a fatal error: gets MuJoCo's message, returns the error to print.
pub type RunFinisher = Box<dyn FnOnce(&str) -> String>;

thread_local! {
    /// What the thread is setting up (innermost last): "robot file X", "config Y".
    static SET_UP: RefCell<Vec<String>> = const { RefCell::new(Vec::new()) };
    /// The finisher of the run the thread is stepping.
    static RUN: RefCell<Option<RunFinisher>> = const { RefCell::new(None) };
    /// The step the thread's run is at and its simulated time (s).
    static POSITION: Cell<(u64, f64)> = const { Cell::new((0, 0.0)) };
}

/// The scratch folders of the process ([`super::scratch_dir`]), removed before a fatal error
/// ends the process (their guards' destructors do not run then).
static SCRATCH: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Routes MuJoCo's messages into SimSerpent (see the module doc).
///
/// # Safety
/// No other thread may use MuJoCo while this runs: call it first thing in `main`.
#[allow(unsafe_code)]
pub unsafe fn install() {
    // SAFETY: the caller guarantees no other thread uses MuJoCo yet.
    unsafe { mujoco_rs::prelude::set_log_handler(handle) };
}

/// Until the guard is dropped, a fatal MuJoCo error on this thread is an error of `what` (a
/// file, named in the message: "robot file X"), exit code 2.
pub fn set_up(what: String) -> SetUp {
    SET_UP.with(|s| s.borrow_mut().push(what));
    SetUp(())
}

/// See [`set_up`].
#[must_use]
pub struct SetUp(());

impl Drop for SetUp {
    fn drop(&mut self) {
        SET_UP.with(|s| {
            s.borrow_mut().pop();
        });
    }
}

/// Until the guard is dropped, a fatal MuJoCo error on this thread calls `finish` (which ends
/// the run: tables and manifest) before the process exits with code 1.
pub fn during_run(finish: RunFinisher) -> DuringRun {
    RUN.with(|r| *r.borrow_mut() = Some(finish));
    POSITION.with(|p| p.set((0, 0.0)));
    DuringRun(())
}

/// See [`during_run`].
#[must_use]
pub struct DuringRun(());

impl Drop for DuringRun {
    fn drop(&mut self) {
        RUN.with(|r| r.borrow_mut().take());
    }
}

/// The step the run on this thread is at (`k`) and its simulated time (s): the step loop sets it
/// at the start of every step (one thread-local store).
#[inline]
pub fn at_step(k: u64, time_secs: f64) {
    POSITION.with(|p| p.set((k, time_secs)));
}

/// The step and simulated time last set by [`at_step`] on this thread.
pub fn position() -> (u64, f64) {
    POSITION.with(Cell::get)
}

pub(crate) fn register_scratch(path: PathBuf) {
    if let Ok(mut s) = SCRATCH.lock() {
        s.push(path);
    }
}

pub(crate) fn unregister_scratch(path: &std::path::Path) {
    if let Ok(mut s) = SCRATCH.lock() {
        s.retain(|p| p != path);
    }
}

/// The text of a MuJoCo message: `func: subject` and the body, cut to [`MAX_MESSAGE_CHARS`].
fn text_of(message: &MjLogMessage) -> String {
    let func = message.func().unwrap_or_default();
    let body = message.body().unwrap_or_default();
    let mut text = String::new();
    if !func.is_empty() {
        text.push_str(func);
        text.push_str(": ");
    }
    text.push_str(message.subject());
    if !body.is_empty() {
        text.push('\n');
        text.push_str(body);
    }
    if text.chars().count() > MAX_MESSAGE_CHARS {
        text = text.chars().take(MAX_MESSAGE_CHARS).collect::<String>() + "…";
    }
    text
}

/// What MuJoCo's message suggests to change, if anything.
fn hint(message: &str) -> &'static str {
    if message.contains("size memory") {
        ""
    } else if message.contains("memory") || message.contains("stack") {
        " (the model's memory is too small for what it simulates: raise `<size memory=\"…\"/>` in the model, or \
         leave it out so that MuJoCo sizes it)"
    } else {
        ""
    }
}

/// The handler: warnings and info to the log; a fatal error ends the process (module doc).
fn handle(message: &MjLogMessage) {
    // Nothing may unwind out of this function (it is called from C).
    let fatal = std::panic::catch_unwind(|| {
        if message.level() != MjtLogLevel::mjLOG_ERROR {
            to_log(message);
            return None;
        }
        Some(text_of(message))
    });
    match fatal {
        Ok(None) => {}
        Ok(Some(text)) => end_process(&text),
        Err(_) => end_process("(a message that could not be read)"),
    }
}

fn to_log(message: &MjLogMessage) {
    let level = match message.level() {
        MjtLogLevel::mjLOG_DEBUG => log::Level::Debug,
        MjtLogLevel::mjLOG_INFO => log::Level::Info,
        MjtLogLevel::mjLOG_WARNING => log::Level::Warn,
        MjtLogLevel::mjLOG_ERROR => log::Level::Error,
    };
    if level <= log::max_level() {
        log::log!(target: "mujoco", level, "{}", text_of(message));
    }
}

/// Ends what the thread was doing (module doc), prints the error and exits.
fn end_process(text: &str) -> ! {
    let ended = std::panic::catch_unwind(|| {
        if let Ok(mut scratch) = SCRATCH.lock() {
            for path in scratch.drain(..) {
                let _ = std::fs::remove_dir_all(path);
            }
        }
        if let Some(finish) = RUN.with(|r| r.try_borrow_mut().ok().and_then(|mut r| r.take())) {
            return (1, finish(text));
        }
        let what = SET_UP.with(|s| s.try_borrow().ok().and_then(|s| s.last().cloned()));
        match what {
            Some(what) => (
                2,
                format!("{what}: MuJoCo stopped with a fatal error while setting up the model: {text}{}", hint(text)),
            ),
            None => (1, format!("MuJoCo stopped with a fatal error: {text}{}", hint(text))),
        }
    });
    let (code, error) = ended.unwrap_or_else(|_| (1, format!("MuJoCo stopped with a fatal error: {text}")));
    {
        use std::io::Write;
        let mut err = std::io::stderr().lock();
        let _ = writeln!(err, "error: {error}");
        let _ = err.flush();
    }
    log::logger().flush();
    std::process::exit(code)
}

/// The error of a run that a fatal MuJoCo error stopped at step `step`, time `time_secs`.
pub fn run_error(text: &str, time_secs: f64, step: u64) -> String {
    format!(
        "MuJoCo stopped the simulation with a fatal error at t = {time_secs:.6} s (step {step}): {text}{}",
        hint(text)
    )
}

//! A spinner on stderr for set-up that takes more than a second (generating and compiling a
//! large model can take tens of seconds, before the run's progress bar can start): shown only
//! on a terminal, drawn by its own thread, cleared when the set-up ends.

use std::io::IsTerminal;
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// How long set-up runs before the spinner appears.
pub const SHOW_AFTER: Duration = Duration::from_secs(1);

/// The spinner of one set-up; dropping it stops and clears it.
pub struct SetupProgress {
    phase: Arc<Mutex<&'static str>>,
    stop: Option<mpsc::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl SetupProgress {
    /// Starts the set-up phase `phase` ("generating the model"); draws nothing unless `enabled`,
    /// stderr is a terminal and the set-up takes longer than [`SHOW_AFTER`].
    pub fn start(enabled: bool, phase: &'static str) -> Self {
        let phase = Arc::new(Mutex::new(phase));
        if !enabled || !std::io::stderr().is_terminal() {
            return Self { phase, stop: None, thread: None };
        }
        let (stop, stopped) = mpsc::channel::<()>();
        let shown = Arc::clone(&phase);
        let thread = std::thread::Builder::new()
            .name("setup-progress".into())
            .spawn(move || {
                if stopped.recv_timeout(SHOW_AFTER) != Err(RecvTimeoutError::Timeout) {
                    return; // done within a second: nothing to show
                }
                let bar = indicatif::ProgressBar::new_spinner().with_elapsed(SHOW_AFTER);
                if let Ok(style) = indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})") {
                    bar.set_style(style);
                }
                loop {
                    bar.set_message(shown.lock().map(|p| *p).unwrap_or_default());
                    bar.tick();
                    if stopped.recv_timeout(Duration::from_millis(100)) != Err(RecvTimeoutError::Timeout) {
                        break;
                    }
                }
                bar.finish_and_clear();
            })
            .ok();
        Self { phase, stop: Some(stop), thread }
    }

    /// Moves on to the next phase ("compiling the model").
    pub fn phase(&self, phase: &'static str) {
        if let Ok(mut p) = self.phase.lock() {
            *p = phase;
        }
    }
}

impl Drop for SetupProgress {
    fn drop(&mut self) {
        drop(self.stop.take());
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

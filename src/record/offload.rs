//! Writing off the step-loop thread, shared by every file a run writes as it goes (the tables,
//! the ROS 2 bag `run.mcap`, `state.csv`).
//!
//! The step loop only *fills* rows: [`Offload::slot`] gives it the next preallocated row buffer
//! of a [`Sink`], the loop copies the instant's numbers into it (no allocation, no formatting)
//! and [`Offload::commit`]s it. Rows travel to a writer thread of their own in batches of
//! [`BATCH`] over a bounded channel; the writer thread formats and writes them, in order, and
//! sends each batch back for reuse. [`POOL`] batches exist, allocated when the file is created:
//! the loop runs at most `POOL × BATCH` rows ahead of the file and waits only when the writer
//! thread is that far behind.
//!
//! A write error on the writer thread stops the writing at that row (the sink keeps what it
//! wrote, whole rows); the loop learns it when it next needs a fresh batch or flushes, and
//! [`Offload::finish`] returns it. [`Offload::inline`] does the same work on the calling thread
//! (the synchronous path: for comparisons and tests; the files are byte for byte the same).

use super::RecordError;
use std::cell::RefCell;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Arc, Mutex};

/// Rows per batch handed to the writer thread: one channel send (one wake-up of a sleeping
/// writer thread) per batch rather than per row.
pub const BATCH: usize = 16;

/// Batches in flight between the loop and the writer thread (by default; see
/// [`Offload::with_pool`]).
pub const POOL: usize = 8;

/// What the writer threads of a run cost, summed over them (`simserpent bench` reports it per
/// step): their CPU time, and how often and how long the step loop waited for them. Writer
/// threads started on a thread that has an account ([`account_writers`]) add to it when they end.
#[derive(Debug, Default)]
pub struct WriterAccount {
    cpu_ns: AtomicU64,
    threads: AtomicU64,
    waits: AtomicU64,
    wait_ns: AtomicU64,
    longest_batch_ns: AtomicU64,
    /// The writer threads drop the rows they receive instead of writing them (a dummy sink:
    /// the bench measures the step loop's side of the hand-over without the writer's work).
    discard: bool,
}

/// A snapshot of a [`WriterAccount`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WriterTotals {
    /// CPU time of all writer threads that ended, summed (ns).
    pub cpu_ns: u64,
    /// Writer threads that ended.
    pub threads: u64,
    /// Times the step loop found no free batch, or flushed, and so waited for a writer thread.
    pub waits: u64,
    /// Wall time the step loop spent in those waits (ns).
    pub wait_ns: u64,
    /// The most CPU time a writer thread spent on one batch of [`BATCH`] rows (ns): its longest
    /// burst of work (say, a Parquet row group compressed and written at once). When it is
    /// longer than the loop needs for `POOL × BATCH` steps, the loop waits even on a free core.
    pub longest_batch_ns: u64,
}

impl WriterAccount {
    /// An empty account; with `discard` its writer threads write nothing (see the field).
    pub fn new(discard: bool) -> Self {
        Self { discard, ..Self::default() }
    }

    /// What was added so far.
    pub fn totals(&self) -> WriterTotals {
        WriterTotals {
            cpu_ns: self.cpu_ns.load(Ordering::Acquire),
            threads: self.threads.load(Ordering::Acquire),
            waits: self.waits.load(Ordering::Acquire),
            wait_ns: self.wait_ns.load(Ordering::Acquire),
            longest_batch_ns: self.longest_batch_ns.load(Ordering::Acquire),
        }
    }
}

thread_local! {
    /// The account of writer threads started on this thread, if any.
    static ACCOUNT: RefCell<Option<Arc<WriterAccount>>> = const { RefCell::new(None) };
}

/// Until the guard is dropped, writer threads started on the calling thread add to `account`
/// (the account before is restored then).
pub fn account_writers(account: Arc<WriterAccount>) -> AccountGuard {
    AccountGuard(ACCOUNT.with(|a| a.borrow_mut().replace(account)))
}

/// See [`account_writers`].
pub struct AccountGuard(Option<Arc<WriterAccount>>);

impl Drop for AccountGuard {
    fn drop(&mut self) {
        let before = self.0.take();
        ACCOUNT.with(|a| *a.borrow_mut() = before);
    }
}

/// What the writer thread does with the rows of one file (or group of files).
pub trait Sink: Send + 'static {
    /// A preallocated row buffer, filled by the step loop.
    type Row: Send + 'static;
    /// Formats and writes one row.
    fn write(&mut self, row: &Self::Row) -> Result<(), RecordError>;
    /// Pushes written rows to the files (whole rows).
    fn flush(&mut self) -> Result<(), RecordError>;
}

/// Up to [`BATCH`] filled rows.
struct Batch<R> {
    rows: Vec<R>,
    len: usize,
}

enum ToWriter<R> {
    Rows(Box<Batch<R>>),
    /// Flush, and answer when done (the error, if any, is in the shared slot).
    Flush(SyncSender<()>),
}

/// The writer thread's side.
struct Threaded<S: Sink> {
    /// Batches to the writer thread; `None` once finished.
    to_writer: Option<SyncSender<ToWriter<S::Row>>>,
    /// Written batches back from the writer thread, for reuse.
    free: Receiver<Box<Batch<S::Row>>>,
    /// The batch being filled, if any.
    current: Option<Box<Batch<S::Row>>>,
    /// How often the loop found no free batch and waited (logged at the end).
    waits: u64,
    /// Wall time of those waits and of flushes (ns).
    wait_ns: u64,
    /// Where the writer thread's cost goes, if anywhere.
    account: Option<Arc<WriterAccount>>,
    writer: Option<std::thread::JoinHandle<S>>,
    /// The writer thread's first error, for the loop to take.
    error: Arc<Mutex<Option<RecordError>>>,
    /// Set by the writer thread when it put an error into `error`.
    failed: Arc<AtomicBool>,
}

/// The calling thread's side (the synchronous path).
struct Inline<S: Sink> {
    sink: S,
    row: S::Row,
    /// After the first error nothing more is written (as on the writer thread).
    failed: bool,
}

enum Mode<S: Sink> {
    Threaded(Threaded<S>),
    Inline(Inline<S>),
}

/// A [`Sink`] fed from the step loop (see the module documentation).
pub struct Offload<S: Sink> {
    mode: Mode<S>,
    /// Names the work in errors and logs (say, `tables` or `run.mcap`).
    what: PathBuf,
}

fn serve<S: Sink>(
    mut sink: S,
    rows: Receiver<ToWriter<S::Row>>,
    free: SyncSender<Box<Batch<S::Row>>>,
    error: &Mutex<Option<RecordError>>,
    failed: &AtomicBool,
    account: Option<&WriterAccount>,
) -> S {
    let discard = account.is_some_and(|a| a.discard);
    let fail = |e: RecordError| {
        if let Ok(mut slot) = error.lock() {
            slot.get_or_insert(e);
        }
        failed.store(true, Ordering::Release);
    };
    for message in rows {
        match message {
            ToWriter::Rows(mut batch) => {
                // Only for an account (the bench): one clock read per batch.
                let cpu_before = account.map(|_| crate::cpu_time::thread_cpu_ns());
                for row in batch.rows.iter().take(batch.len) {
                    if !discard
                        && !failed.load(Ordering::Acquire)
                        && let Err(e) = sink.write(row)
                    {
                        fail(e);
                    }
                }
                batch.len = 0;
                if let (Some(a), Some(before)) = (account, cpu_before) {
                    let spent = crate::cpu_time::thread_cpu_ns().saturating_sub(before);
                    a.longest_batch_ns.fetch_max(spent, Ordering::AcqRel);
                }
                // The pool holds exactly the batches allocated: this never blocks.
                let _ = free.try_send(batch);
            }
            ToWriter::Flush(answer) => {
                if !failed.load(Ordering::Acquire)
                    && let Err(e) = sink.flush()
                {
                    fail(e);
                }
                let _ = answer.send(());
            }
        }
    }
    sink
}

impl<S: Sink> Offload<S> {
    /// Starts the writer thread for `sink`; `row` makes the `POOL × BATCH` row buffers (all of
    /// them now). `what` names the work in errors (a file or `tables`).
    pub fn spawn(sink: S, row: impl FnMut() -> S::Row, what: PathBuf) -> Result<Self, RecordError> {
        Self::spawn_with_pool(sink, row, what, POOL)
    }

    /// [`Offload::spawn`] with `batches` batches in flight instead of [`POOL`] (at least 1): the
    /// loop runs up to `batches × BATCH` rows ahead of the writer thread, which must cover the
    /// writer's longest burst of work for the loop never to wait on a free core.
    fn spawn_with_pool(
        sink: S,
        mut row: impl FnMut() -> S::Row,
        what: PathBuf,
        batches: usize,
    ) -> Result<Self, RecordError> {
        let batches = batches.max(1);
        let (to_writer, rows) = sync_channel(batches);
        let (give_back, free) = sync_channel(batches);
        for _ in 0..batches {
            let rows = (0..BATCH).map(|_| row()).collect();
            let _ = give_back.try_send(Box::new(Batch { rows, len: 0 }));
        }
        let error = Arc::new(Mutex::new(None));
        let failed = Arc::new(AtomicBool::new(false));
        let (slot, flag) = (error.clone(), failed.clone());
        let account = ACCOUNT.with(|a| a.borrow().clone());
        let theirs = account.clone();
        let writer = std::thread::Builder::new()
            .name("simserpent-writer".into())
            .spawn(move || {
                let sink = serve(sink, rows, give_back, &slot, &flag, theirs.as_deref());
                if let Some(a) = theirs {
                    a.cpu_ns.fetch_add(crate::cpu_time::thread_cpu_ns(), Ordering::AcqRel);
                    a.threads.fetch_add(1, Ordering::AcqRel);
                }
                sink
            })
            .map_err(|source| RecordError::Io { path: what.clone(), source })?;
        let threaded = Threaded {
            to_writer: Some(to_writer),
            free,
            current: None,
            waits: 0,
            wait_ns: 0,
            account,
            writer: Some(writer),
            error,
            failed,
        };
        Ok(Self { mode: Mode::Threaded(threaded), what })
    }

    /// The same work on the calling thread: every committed row is written at once.
    pub fn inline(sink: S, mut row: impl FnMut() -> S::Row, what: PathBuf) -> Self {
        Self { mode: Mode::Inline(Inline { sink, row: row(), failed: false }), what }
    }

    /// Either: on a writer thread (`threaded`) or on the calling thread.
    pub fn new(sink: S, row: impl FnMut() -> S::Row, what: PathBuf, threaded: bool) -> Result<Self, RecordError> {
        Self::with_pool(sink, row, what, threaded, POOL)
    }

    /// [`Offload::new`] with `batches` batches in flight on the writer thread (see
    /// [`Offload::spawn_with_pool`]; the inline path holds one row whatever `batches`).
    pub fn with_pool(
        sink: S,
        row: impl FnMut() -> S::Row,
        what: PathBuf,
        threaded: bool,
        batches: usize,
    ) -> Result<Self, RecordError> {
        if threaded { Self::spawn_with_pool(sink, row, what, batches) } else { Ok(Self::inline(sink, row, what)) }
    }

    /// The writer thread ended unexpectedly (it panicked).
    fn writer_gone(what: &std::path::Path) -> RecordError {
        RecordError::Io { path: what.to_path_buf(), source: std::io::Error::other("the writer thread stopped") }
    }

    /// The row buffer to fill next. It holds whatever an earlier row left in it: fill every
    /// value. A buffer that is not [`Offload::commit`]ted is handed out again. Fails with the
    /// writer thread's first error, once there is one.
    pub fn slot(&mut self) -> Result<&mut S::Row, RecordError> {
        match &mut self.mode {
            Mode::Inline(inline) => Ok(&mut inline.row),
            Mode::Threaded(t) => {
                if t.current.is_none() {
                    t.writer_error()?;
                    let batch = match t.free.try_recv() {
                        Ok(batch) => batch,
                        Err(_) => {
                            t.waits += 1;
                            let waiting = std::time::Instant::now();
                            let Ok(batch) = t.free.recv() else { return Err(Self::writer_gone(&self.what)) };
                            t.wait_ns += u64::try_from(waiting.elapsed().as_nanos()).unwrap_or(u64::MAX);
                            batch
                        }
                    };
                    t.current = Some(batch);
                }
                match t.current.as_mut() {
                    Some(batch) => Ok(&mut batch.rows[batch.len]),
                    None => Err(Self::writer_gone(&self.what)),
                }
            }
        }
    }

    /// Hands the row filled in [`Offload::slot`] on: to the writer thread (in a batch, once the
    /// batch is full) or, inline, writes it now.
    pub fn commit(&mut self) -> Result<(), RecordError> {
        match &mut self.mode {
            Mode::Inline(inline) => {
                if inline.failed {
                    return Ok(());
                }
                inline.sink.write(&inline.row).inspect_err(|_| inline.failed = true)
            }
            Mode::Threaded(t) => {
                let Some(mut batch) = t.current.take() else { return Ok(()) };
                batch.len += 1;
                if batch.len < BATCH {
                    t.current = Some(batch);
                    return Ok(());
                }
                t.hand_over(batch).map_err(|()| Self::writer_gone(&self.what))
            }
        }
    }

    /// Waits until every committed row is written and flushed to the files.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        match &mut self.mode {
            Mode::Inline(inline) => {
                if inline.failed {
                    return Ok(());
                }
                inline.sink.flush().inspect_err(|_| inline.failed = true)
            }
            Mode::Threaded(t) => {
                t.hand_over_partial().map_err(|()| Self::writer_gone(&self.what))?;
                let (answer, reply) = sync_channel(1);
                let Some(sender) = t.to_writer.as_ref() else { return Ok(()) };
                let waiting = std::time::Instant::now();
                if sender.send(ToWriter::Flush(answer)).is_err() || reply.recv().is_err() {
                    return Err(Self::writer_gone(&self.what));
                }
                t.waits += 1;
                t.wait_ns += u64::try_from(waiting.elapsed().as_nanos()).unwrap_or(u64::MAX);
                t.writer_error()
            }
        }
    }

    /// Writes the rows still in flight and stops the writer thread. Returns the sink (to close
    /// its files; `None` only when the writer thread panicked) and the first write error not
    /// returned yet.
    pub fn finish(self) -> (Option<S>, Result<(), RecordError>) {
        match self.mode {
            Mode::Inline(inline) => (Some(inline.sink), Ok(())),
            Mode::Threaded(mut t) => {
                // The last rows (a send fails only when the writer thread is gone: joined below).
                let _ = t.hand_over_partial();
                log::debug!(
                    "{}: the step loop waited {} times ({:.3} s) for the writer thread",
                    self.what.display(),
                    t.waits,
                    t.wait_ns as f64 * 1e-9
                );
                if let Some(a) = &t.account {
                    a.waits.fetch_add(t.waits, Ordering::AcqRel);
                    a.wait_ns.fetch_add(t.wait_ns, Ordering::AcqRel);
                }
                // Hanging up ends the writer thread after the rows in flight.
                drop(t.to_writer.take());
                let joined = t.writer.take().map(std::thread::JoinHandle::join);
                match joined {
                    Some(Ok(sink)) => {
                        let pending = t.error.lock().ok().and_then(|mut slot| slot.take());
                        (Some(sink), pending.map_or(Ok(()), Err))
                    }
                    _ => (None, Err(Self::writer_gone(&self.what))),
                }
            }
        }
    }
}

impl<S: Sink> Threaded<S> {
    /// The writer thread's first error, once it has one (taken: the loop stops with it).
    fn writer_error(&mut self) -> Result<(), RecordError> {
        if !self.failed.load(Ordering::Acquire) {
            return Ok(());
        }
        match self.error.lock().ok().and_then(|mut slot| slot.take()) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    fn hand_over(&mut self, batch: Box<Batch<S::Row>>) -> Result<(), ()> {
        match self.to_writer.as_ref().map(|t| t.send(ToWriter::Rows(batch))) {
            Some(Ok(())) => Ok(()),
            _ => Err(()),
        }
    }

    /// Hands over the rows of a batch not full yet.
    fn hand_over_partial(&mut self) -> Result<(), ()> {
        match self.current.take() {
            Some(batch) if batch.len > 0 => self.hand_over(batch),
            Some(batch) => {
                self.current = Some(batch);
                Ok(())
            }
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Collects rows; fails at a given row.
    struct Collect {
        seen: Vec<u64>,
        fail_at: Option<u64>,
        flushes: usize,
    }

    impl Sink for Collect {
        type Row = u64;
        fn write(&mut self, row: &u64) -> Result<(), RecordError> {
            if Some(*row) == self.fail_at {
                return Err(RecordError::Io { path: "x.csv".into(), source: std::io::Error::other("disk full") });
            }
            self.seen.push(*row);
            Ok(())
        }
        fn flush(&mut self) -> Result<(), RecordError> {
            self.flushes += 1;
            Ok(())
        }
    }

    fn push<S: Sink<Row = u64>>(o: &mut Offload<S>, n: u64) -> Result<(), RecordError> {
        *o.slot()? = n;
        o.commit()
    }

    #[test]
    fn rows_arrive_in_order_through_the_thread_and_inline() {
        for threaded in [true, false] {
            let sink = Collect { seen: Vec::new(), fail_at: None, flushes: 0 };
            let mut o = Offload::new(sink, || 0, "t".into(), threaded).expect("started");
            // More than the pool holds, and a partial last batch; a flush in between.
            for n in 0..(3 * POOL * BATCH + 5) as u64 {
                push(&mut o, n).expect("row");
                if n == 100 {
                    o.flush().expect("flush");
                }
            }
            let (sink, result) = o.finish();
            result.expect("finished");
            let sink = sink.expect("sink back");
            assert_eq!(sink.seen, (0..(3 * POOL * BATCH + 5) as u64).collect::<Vec<_>>());
            assert_eq!(sink.flushes, 1);
        }
    }

    #[test]
    fn a_larger_pool_lets_the_loop_run_that_far_ahead_of_a_stalled_writer() {
        // The writer thread blocks in its first row until released: the loop fills the pool.
        struct Stall(std::sync::mpsc::Receiver<()>);
        impl Sink for Stall {
            type Row = u64;
            fn write(&mut self, _: &u64) -> Result<(), RecordError> {
                let _ = self.0.recv();
                Ok(())
            }
            fn flush(&mut self) -> Result<(), RecordError> {
                Ok(())
            }
        }
        for batches in [POOL, 4 * POOL] {
            let (release, stalled) = sync_channel(0);
            let mut o = Offload::with_pool(Stall(stalled), || 0, "t".into(), true, batches).expect("started");
            // All batches but the one on the writer thread can be filled without waiting.
            for n in 0..(batches * BATCH) as u64 {
                push(&mut o, n).expect("row");
            }
            let Mode::Threaded(t) = &o.mode else { panic!("threaded") };
            assert_eq!(t.waits, 0, "{batches} batches: the loop waited");
            drop(release);
            let (_, result) = o.finish();
            result.expect("finished");
        }
    }

    #[test]
    fn a_write_error_on_the_writer_thread_reaches_the_loop_and_stops_the_writing() {
        let sink = Collect { seen: Vec::new(), fail_at: Some(40), flushes: 0 };
        let mut o = Offload::spawn(sink, || 0, "t".into()).expect("started");
        let mut error = None;
        for n in 0..10_000 {
            if let Err(e) = push(&mut o, n) {
                error = Some(e);
                break;
            }
        }
        let error = error.expect("the loop learns the error");
        assert!(error.to_string().contains("x.csv") && error.to_string().contains("disk full"), "{error}");
        let (sink, result) = o.finish();
        assert!(result.is_ok(), "the error was taken by the loop already");
        assert_eq!(sink.expect("sink back").seen, (0..40).collect::<Vec<_>>());
    }

    #[test]
    fn an_error_in_the_last_rows_comes_from_finish() {
        let sink = Collect { seen: Vec::new(), fail_at: Some(3), flushes: 0 };
        let mut o = Offload::spawn(sink, || 0, "t".into()).expect("started");
        for n in 0..5 {
            push(&mut o, n).expect("the error is not known yet");
        }
        let (_, result) = o.finish();
        assert!(result.expect_err("finish returns it").to_string().contains("x.csv"));
    }
}

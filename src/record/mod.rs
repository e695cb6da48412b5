//! Recording: the run folder, its manifest and the streaming tables.
//!
//! Layout of `runs/<run_name>-<UTC time>/`:
//! - `config.toml`: the resolved configuration (every key, after defaults and `--set`);
//! - `model.xml`: the generated MJCF (MuJoCo loads it unchanged);
//! - `manifest.json`: versions, seed, status (`incomplete` while running or after an
//!   interruption, then `complete` or `failed` with the reason), wall time, steps;
//! - `links.csv`, `joints.csv`, `sensors.csv`: one row per recorded step (wide);
//! - `contacts.csv`: one row per contact per recorded step (long format);
//! - `estimates.csv` (with `[estimation] enabled`): per link the contact estimates the
//!   controller saw next to the true obstacle and floor forces, one row per recorded step.
//!
//! With `recording.format = "parquet"` or `"both"` the tables are (also) written as
//! `<table>.parquet` with the same columns ([`Table`] fans every value out to both formats).
//!
//! The columns of every table are listed once, in `columns.rs`: each quantity is one entry
//! (its `[recording]` switch, names with units, type and the code that reads it from the
//! [`Snapshot`]), and the header and every row are built from that list.

mod columns;
mod manifest;
#[cfg(feature = "parquet")]
mod parquet;
mod sink;
mod table;

pub use manifest::{Manifest, RunStatus, SpaceReserve};
#[cfg(feature = "parquet")]
pub use parquet::ParquetTable;
pub use sink::{ColumnKind, Table, TableSink};
pub use table::CsvTable;

use crate::config::Recording;
use crate::sim::{Index, Snapshot};
use columns::{ContactNames, Layout, TABLES, Wanted};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Errors of writing a run folder; they always name the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    /// An I/O failure on a file or folder.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RecordError + '_ {
    move |source| RecordError::Io { path: path.to_path_buf(), source }
}

/// UTC time as `YYYYMMDDTHHMMSSZ` from seconds since the Unix epoch (civil-from-days algorithm
/// of H. Hinnant, public domain).
pub fn utc_stamp(unix_secs: u64) -> String {
    let days = (unix_secs / 86_400) as i64;
    let rem = unix_secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// Creates `<output_dir>/<run_name>-<stamp>/` (with `-2`, `-3`, … if it exists already).
pub fn create_run_folder(output_dir: &Path, run_name: &str, stamp: &str) -> Result<PathBuf, RecordError> {
    std::fs::create_dir_all(output_dir).map_err(io_err(output_dir))?;
    let mut attempt = 1;
    loop {
        let name = if attempt == 1 { format!("{run_name}-{stamp}") } else { format!("{run_name}-{stamp}-{attempt}") };
        let path = output_dir.join(name);
        match std::fs::create_dir(&path) {
            Ok(()) => return Ok(path),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 1000 => attempt += 1,
            Err(e) => return Err(io_err(&path)(e)),
        }
    }
}

/// The tables of one run, written as the run goes, on a thread of their own: the step loop
/// only copies each recorded [`Snapshot`] into a batch from a fixed pool and hands the batch
/// over when it holds [`BATCH`] rows (or at a flush and at the end); the writer thread formats
/// the numbers (CSV) or encodes the columns (Parquet) and writes the files, in the order the
/// rows came. The files are byte for byte those of writing in the loop.
///
/// Handing over batches rather than single rows wakes the writer thread once per [`BATCH`]
/// rows instead of once per row (each wake-up is a system call on the step-loop thread).
///
/// A write error on the writer thread stops its writing at that row; the loop learns it at its
/// next [`Recorder::write`] or [`Recorder::flush`] (a few batches later at most) and
/// [`Recorder::finish`] returns it, with the rows that reached the files.
pub struct Recorder {
    /// Batches to the writer thread; `None` once finished.
    to_writer: Option<std::sync::mpsc::SyncSender<ToWriter>>,
    /// Written batches back from the writer thread, for reuse.
    free: std::sync::mpsc::Receiver<Box<Batch>>,
    /// The batch being filled, if any.
    current: Option<Box<Batch>>,
    /// How often the loop found no free batch and waited for the writer thread (logged at the
    /// end: a writer that cannot keep up shows here).
    waits: u64,
    /// The writer thread; it returns the tables.
    writer: Option<std::thread::JoinHandle<Tables>>,
    /// The writer thread's first error, for the loop to take.
    error: Arc<Mutex<Option<RecordError>>>,
    /// Set by the writer thread when it put an error into `error`.
    failed: Arc<AtomicBool>,
}

/// Rows per batch handed to the writer thread.
pub const BATCH: usize = 16;

/// Batches in flight between the loop and the writer thread: the loop runs at most
/// `POOL * BATCH` rows ahead of the files.
const POOL: usize = 8;

/// Up to [`BATCH`] recorded rows: step numbers and snapshots (all allocated once).
struct Batch {
    steps: [u64; BATCH],
    snapshots: Vec<Snapshot>,
    len: usize,
}

enum ToWriter {
    Rows(Box<Batch>),
    /// Flush, and answer when done (the error, if any, is in the shared slot).
    Flush(std::sync::mpsc::SyncSender<()>),
}

/// The tables themselves, owned by the writer thread.
struct Tables {
    /// The tables the run writes, in manifest order (`links`, `joints`, `sensors`, `contacts`),
    /// each with its resolved columns.
    tables: Vec<(Layout, Table)>,
    names: ContactNames,
}

impl Tables {
    fn write(&mut self, step: u64, s: &Snapshot) -> Result<(), RecordError> {
        for (layout, table) in &mut self.tables {
            // Paths are only copied on error: a recorded step allocates nothing.
            layout
                .write(table, s, step, &self.names)
                .map_err(|source| RecordError::Io { path: table.path().to_path_buf(), source })?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), RecordError> {
        for (_, table) in &mut self.tables {
            table.flush().map_err(|(path, source)| RecordError::Io { path, source })?;
        }
        Ok(())
    }

    fn finish(self) -> (Vec<(String, u64)>, Result<(), RecordError>) {
        let mut out = Vec::new();
        let mut first_error = Ok(());
        for (_, table) in self.tables {
            let (files, error) = table.finish();
            out.extend(files);
            if let (Some((path, source)), Ok(())) = (error, &first_error) {
                first_error = Err(RecordError::Io { path, source });
            }
        }
        (out, first_error)
    }

    /// The writer thread: rows in order until the loop hangs up; after the first error, rows
    /// are only handed back.
    fn serve(
        mut self,
        rows: std::sync::mpsc::Receiver<ToWriter>,
        free: std::sync::mpsc::SyncSender<Box<Batch>>,
        error: &Mutex<Option<RecordError>>,
        failed: &AtomicBool,
    ) -> Self {
        let fail = |e: RecordError| {
            if let Ok(mut slot) = error.lock() {
                slot.get_or_insert(e);
            }
            failed.store(true, Ordering::Release);
        };
        for message in rows {
            match message {
                ToWriter::Rows(mut batch) => {
                    for (step, snapshot) in batch.steps.iter().zip(&batch.snapshots).take(batch.len) {
                        if !failed.load(Ordering::Acquire)
                            && let Err(e) = self.write(*step, snapshot)
                        {
                            fail(e);
                        }
                    }
                    batch.len = 0;
                    // The pool holds exactly the batches allocated: this never blocks.
                    let _ = free.try_send(batch);
                }
                ToWriter::Flush(answer) => {
                    if !failed.load(Ordering::Acquire)
                        && let Err(e) = self.flush()
                    {
                        fail(e);
                    }
                    let _ = answer.send(());
                }
            }
        }
        self
    }
}

impl Recorder {
    /// Creates the tables in `folder` with headers for the robot described by `index`.
    ///
    /// With `surfaces` (the config has floor surfaces) `links` gets one more column per link,
    /// `link_ii_surface`: the index of the surface under the link's centre in `ground.surfaces`,
    /// or −1 on the plain floor. When a table cannot be created, none is left in `folder`.
    ///
    /// With `estimation` (contact estimation runs in the loop) the `estimates` table is written.
    pub fn create(
        folder: &Path,
        flags: &Recording,
        index: &Index,
        surfaces: bool,
        estimation: bool,
    ) -> Result<Self, RecordError> {
        let want = Wanted { flags, surfaces, estimation };
        let links: Vec<&str> = index.links.iter().map(|l| l.name.as_str()).collect();
        let joints: Vec<&str> = index.joints.iter().map(|j| j.name.as_str()).collect();
        let mut tables = Vec::with_capacity(TABLES.len());
        for spec in TABLES {
            if !(spec.on)(want) {
                continue;
            }
            let (layout, header) = Layout::new(spec, want, &links, &joints);
            match Table::typed(folder, spec.name, &header.names, &header.kinds, flags) {
                Ok(table) => tables.push((layout, table)),
                Err(e) => {
                    // A full disk while creating the tables: leave none (they hold no rows yet),
                    // so the manifest's empty table list is the truth.
                    drop(tables);
                    for name in TABLES.iter().map(|s| s.name) {
                        let _ = std::fs::remove_file(folder.join(format!("{name}.csv")));
                        let _ = std::fs::remove_dir_all(folder.join(format!("{name}.parquet")));
                    }
                    return Err(io_err(&folder.join(spec.name))(e));
                }
            }
        }
        let names = ContactNames { geoms: index.geom_names.clone(), bodies: index.body_names.clone() };
        let tables = Tables { tables, names };
        let (to_writer, rows) = std::sync::mpsc::sync_channel(POOL);
        let (give_back, free) = std::sync::mpsc::sync_channel(POOL);
        // The whole pool now: a recorded step allocates nothing (but more contacts than ever).
        for _ in 0..POOL {
            let snapshots = (0..BATCH).map(|_| Snapshot::new(index.links.len(), index.joints.len())).collect();
            let _ = give_back.try_send(Box::new(Batch { steps: [0; BATCH], snapshots, len: 0 }));
        }
        let error = Arc::new(Mutex::new(None));
        let failed = Arc::new(AtomicBool::new(false));
        let (slot, flag) = (error.clone(), failed.clone());
        let writer = std::thread::Builder::new()
            .name("simserpent-recorder".into())
            .spawn(move || tables.serve(rows, give_back, &slot, &flag))
            .map_err(io_err(folder))?;
        Ok(Self { to_writer: Some(to_writer), free, current: None, waits: 0, writer: Some(writer), error, failed })
    }

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

    /// The writer thread ended unexpectedly (it panicked).
    fn writer_gone(&self) -> RecordError {
        RecordError::Io { path: PathBuf::from("tables"), source: std::io::Error::other("the recording thread stopped") }
    }

    /// Appends one snapshot (step number `step`): copies it into the current batch (no
    /// allocation, except for more contacts than ever before) and hands the batch to the writer
    /// thread once it is full; waits only when the writer is a whole pool of batches behind.
    pub fn write(&mut self, step: u64, s: &Snapshot) -> Result<(), RecordError> {
        let mut batch = match self.current.take() {
            Some(batch) => batch,
            None => {
                self.writer_error()?;
                match self.free.try_recv() {
                    Ok(batch) => batch,
                    Err(_) => {
                        self.waits += 1;
                        let Ok(batch) = self.free.recv() else { return Err(self.writer_gone()) };
                        batch
                    }
                }
            }
        };
        let n = batch.len;
        batch.steps[n] = step;
        batch.snapshots[n].copy_from(s);
        batch.len = n + 1;
        if batch.len < BATCH {
            self.current = Some(batch);
            return Ok(());
        }
        self.hand_over(batch)
    }

    /// Sends a batch to the writer thread.
    fn hand_over(&mut self, batch: Box<Batch>) -> Result<(), RecordError> {
        match self.to_writer.as_ref().map(|t| t.send(ToWriter::Rows(batch))) {
            Some(Ok(())) => Ok(()),
            _ => Err(self.writer_gone()),
        }
    }

    /// Hands over the rows of a batch not full yet.
    fn hand_over_partial(&mut self) -> Result<(), RecordError> {
        match self.current.take() {
            Some(batch) if batch.len > 0 => self.hand_over(batch),
            Some(batch) => {
                self.current = Some(batch);
                Ok(())
            }
            None => Ok(()),
        }
    }

    /// Flushes all tables (whole rows reach the files): waits for the writer thread.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.hand_over_partial()?;
        let (answer, reply) = std::sync::mpsc::sync_channel(1);
        let Some(sender) = self.to_writer.as_ref() else { return Ok(()) };
        if sender.send(ToWriter::Flush(answer)).is_err() || reply.recv().is_err() {
            return Err(self.writer_gone());
        }
        self.writer_error()
    }

    /// Flushes and closes all tables, each even when another fails. Returns (file name, rows)
    /// per table file, for the manifest, and the first error. The rows are the whole rows each
    /// file holds, also after a failure: a CSV file is cut back to its last whole row, and a
    /// Parquet part that cannot be closed is deleted (see [`CsvTable::close`]).
    pub fn finish(mut self) -> (Vec<(String, u64)>, Result<(), RecordError>) {
        // The last rows (a send fails only when the writer thread is gone: joined below).
        let _ = self.hand_over_partial();
        log::debug!("recording: the step loop waited {} times for a free batch", self.waits);
        // Hanging up ends the writer thread after the rows in flight.
        drop(self.to_writer.take());
        let Some(writer) = self.writer.take() else {
            return (Vec::new(), Err(self.writer_gone()));
        };
        match writer.join() {
            Ok(tables) => {
                // An error the loop has not taken yet (a failed last row) comes first.
                let pending = self.error.lock().ok().and_then(|mut slot| slot.take());
                let (files, closed) = tables.finish();
                (files, pending.map_or(closed, Err))
            }
            Err(_) => (Vec::new(), Err(self.writer_gone())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_stamp_matches_known_dates() {
        assert_eq!(utc_stamp(0), "19700101T000000Z");
        assert_eq!(utc_stamp(951_782_400), "20000229T000000Z");
        assert_eq!(utc_stamp(1_795_373_261), "20261122T184741Z");
    }
}

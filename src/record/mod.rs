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
mod format;
mod manifest;
pub mod offload;
#[cfg(feature = "parquet")]
mod parquet;
mod reference;
mod sink;
mod table;

pub use format::{ColumnKind, TableSink};
pub(crate) use manifest::sync_folder;
pub use manifest::{Manifest, Ros2Report, RunStatus, RunSummary, SpaceReserve};
#[cfg(feature = "parquet")]
pub use parquet::ParquetTable;
pub use reference::columns_markdown;
pub use sink::Table;
pub use table::CsvTable;

use crate::config::Recording;
use crate::sim::{Index, Snapshot};
use columns::{ContactNames, Layout, TABLES, Wanted};
use offload::{Offload, Sink};
use std::path::{Path, PathBuf};

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

/// The tables of one run, written as the run goes, on a thread of their own ([`offload`]): the
/// step loop only copies each recorded [`Snapshot`] into a preallocated row buffer and hands it
/// over; the writer thread formats the numbers (CSV) or encodes the columns (Parquet) and writes
/// the files, in the order the rows came. The files are byte for byte those of writing in the
/// loop (`threaded = false` in [`Recorder::create`]).
///
/// A write error on the writer thread stops its writing at that row; the loop learns it at its
/// next [`Recorder::write`] or [`Recorder::flush`] (a few batches later at most) and
/// [`Recorder::finish`] returns it, with the rows that reached the files.
pub struct Recorder {
    out: Offload<Tables>,
}

/// Rows per batch handed to the writer thread.
pub use offload::BATCH;

/// Batches of [`BATCH`] rows in flight to the tables' writer thread when Parquet is recorded
/// (512 rows: the loop's lead over the writer must cover a row group written at once).
pub const PARQUET_POOL: usize = 32;

/// One recorded instant: its step number and snapshot.
struct TableRow {
    step: u64,
    snapshot: Snapshot,
}

/// The tables themselves, owned by the writer thread.
struct Tables {
    /// The tables the run writes, in manifest order (`links`, `joints`, `sensors`, `contacts`),
    /// each with its resolved columns.
    tables: Vec<(Layout, Table)>,
    names: ContactNames,
}

impl Sink for Tables {
    type Row = TableRow;

    fn write(&mut self, row: &TableRow) -> Result<(), RecordError> {
        for (layout, table) in &mut self.tables {
            // Paths are only copied on error: a recorded step allocates nothing.
            layout
                .write(table, &row.snapshot, row.step, &self.names)
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
}

impl Tables {
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
}

impl Recorder {
    /// Creates the tables in `folder` with headers for the robot described by `index`, written
    /// on a writer thread (`threaded`) or in the caller's thread.
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
        threaded: bool,
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
        let (n_links, n_joints) = (index.links.len(), index.joints.len());
        // Every row buffer now: a recorded step allocates nothing (but more contacts than ever).
        let row = || TableRow { step: 0, snapshot: Snapshot::new(n_links, n_joints) };
        // Parquet writes a row group at once every `parquet_row_group_rows` rows: measured on
        // the default job, that burst is ~30 ms of the writer thread's CPU time (10 links, ~100
        // ms at 30), longer than the loop needs for the default pool's 128 steps, so the loop
        // would wait for it even with a free core. A pool of
        // PARQUET_POOL batches lets it run ahead through the burst.
        let batches = if flags.format.parquet() { PARQUET_POOL } else { offload::POOL };
        let out = Offload::with_pool(Tables { tables, names }, row, folder.join("tables"), threaded, batches)?;
        Ok(Self { out })
    }

    /// Appends one snapshot (step number `step`): copies it into a row buffer (no allocation,
    /// except for more contacts than ever before) for the writer thread.
    pub fn write(&mut self, step: u64, s: &Snapshot) -> Result<(), RecordError> {
        let row = self.out.slot()?;
        row.step = step;
        row.snapshot.copy_from(s);
        self.out.commit()
    }

    /// Flushes all tables (whole rows reach the files): waits for the writer thread.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.out.flush()
    }

    /// Flushes and closes all tables, each even when another fails. Returns (file name, rows)
    /// per table file, for the manifest, and the first error. The rows are the whole rows each
    /// file holds, also after a failure: a CSV file is cut back to its last whole row, and a
    /// Parquet part that cannot be closed is deleted (see [`CsvTable::close`]).
    pub fn finish(self) -> (Vec<(String, u64)>, Result<(), RecordError>) {
        match self.out.finish() {
            (Some(tables), pending) => {
                // An error the loop has not taken yet (a failed last row) comes first.
                let (files, closed) = tables.finish();
                (files, pending.and(closed))
            }
            (None, gone) => (Vec::new(), gone),
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

//! Where table rows go: a [`TableSink`] (module `format`) takes one row at a time, value by value, and writes it in
//! its file format. [`Table`] fans each value out to the formats that `recording.format` asks for
//! (CSV, Parquet or both), so the [`super::Recorder`] writes every value once and both files get
//! identical columns in the same order.

use super::format::{ColumnKind, TableSink};
use super::table::CsvTable;
use crate::config::Recording;
use std::path::{Path, PathBuf};

impl TableSink for CsvTable {
    fn num(&mut self, value: f64) -> std::io::Result<()> {
        CsvTable::num(self, value)
    }
    fn int(&mut self, value: u64) -> std::io::Result<()> {
        CsvTable::int(self, value)
    }
    fn text(&mut self, value: &str) -> std::io::Result<()> {
        CsvTable::text(self, value)
    }
    fn end_row(&mut self) -> std::io::Result<()> {
        CsvTable::end_row(self)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        CsvTable::flush(self)
    }
    fn path(&self) -> &Path {
        CsvTable::path(self)
    }
    fn rows(&self) -> u64 {
        CsvTable::rows(self)
    }
}

#[cfg(feature = "parquet")]
type ParquetSink = super::parquet::ParquetDataset;

/// Stand-in when the `parquet` feature is off: never constructed (the config validation rejects
/// `recording.format = "parquet"` or `"both"` in such a build).
#[cfg(not(feature = "parquet"))]
enum ParquetSink {}

#[cfg(not(feature = "parquet"))]
impl ParquetSink {
    fn num(&mut self, _: f64) -> std::io::Result<()> {
        match *self {}
    }
    fn nums(&mut self, _: &[f64]) -> std::io::Result<()> {
        match *self {}
    }
    fn int(&mut self, _: u64) -> std::io::Result<()> {
        match *self {}
    }
    fn text(&mut self, _: &str) -> std::io::Result<()> {
        match *self {}
    }
    fn end_row(&mut self) -> std::io::Result<()> {
        match *self {}
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match *self {}
    }
    fn close(self) -> (u64, std::io::Result<()>) {
        match self {}
    }
    fn path(&self) -> &Path {
        match *self {}
    }
    fn rows(&self) -> u64 {
        match *self {}
    }
}

/// A file that failed: its path and the OS error.
pub type FileError = (PathBuf, std::io::Error);

/// One logical table (`links`, `joints`, …) written as `<name>.csv`, `<name>.parquet` or both.
pub struct Table {
    csv: Option<CsvTable>,
    parquet: Option<ParquetSink>,
    /// The Parquet file failed (so [`Table::path`] names it rather than the CSV).
    parquet_failed: bool,
}

impl Table {
    /// A table whose columns are all numbers (the wide tables).
    pub fn numeric(folder: &Path, name: &str, header: &[String], recording: &Recording) -> std::io::Result<Self> {
        Self::typed(folder, name, header, &vec![ColumnKind::Float; header.len()], recording)
    }

    /// A table with the given column kinds (`kinds.len() == header.len()`).
    pub fn typed(
        folder: &Path,
        name: &str,
        header: &[String],
        kinds: &[ColumnKind],
        recording: &Recording,
    ) -> std::io::Result<Self> {
        debug_assert_eq!(header.len(), kinds.len(), "{name}: header and kinds");
        let csv = if recording.format.csv() || !cfg!(feature = "parquet") {
            Some(CsvTable::create(&folder.join(format!("{name}.csv")), header)?)
        } else {
            None
        };
        #[cfg(feature = "parquet")]
        let parquet = if recording.format.parquet() {
            Some(ParquetSink::create(
                &folder.join(format!("{name}.parquet")),
                header,
                kinds,
                recording.parquet_row_group_rows,
                recording.parquet_rows_per_file,
                recording.parquet_compression,
            )?)
        } else {
            None
        };
        #[cfg(not(feature = "parquet"))]
        let parquet = None;
        Ok(Self { csv, parquet, parquet_failed: false })
    }

    /// The file of the table for error messages: the one that failed, else the CSV if there is
    /// one.
    pub fn path(&self) -> &Path {
        match (&self.csv, &self.parquet) {
            (_, Some(p)) if self.parquet_failed => p.path(),
            (Some(c), _) => c.path(),
            (None, Some(p)) => p.path(),
            (None, None) => Path::new(""),
        }
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        match (&self.csv, &self.parquet) {
            (Some(c), _) => c.rows(),
            (None, Some(p)) => p.rows(),
            (None, None) => 0,
        }
    }

    /// Appends a number to the current row.
    #[inline]
    pub fn num(&mut self, value: f64) -> std::io::Result<()> {
        if let Some(t) = self.csv.as_mut() {
            t.num(value)?;
        }
        if let Some(t) = self.parquet.as_mut() {
            t.num(value).inspect_err(|_| self.parquet_failed = true)?;
        }
        Ok(())
    }

    /// Appends several numbers (each format takes them all at once: one dispatch per group of
    /// values rather than per value; the rows are the same).
    #[inline]
    pub fn nums(&mut self, values: &[f64]) -> std::io::Result<()> {
        if let Some(t) = self.csv.as_mut() {
            t.nums(values)?;
        }
        if let Some(t) = self.parquet.as_mut() {
            t.nums(values).inspect_err(|_| self.parquet_failed = true)?;
        }
        Ok(())
    }

    /// Appends an integer.
    pub fn int(&mut self, value: u64) -> std::io::Result<()> {
        if let Some(t) = self.csv.as_mut() {
            t.int(value)?;
        }
        if let Some(t) = self.parquet.as_mut() {
            t.int(value).inspect_err(|_| self.parquet_failed = true)?;
        }
        Ok(())
    }

    /// Appends a name.
    pub fn text(&mut self, value: &str) -> std::io::Result<()> {
        if let Some(t) = self.csv.as_mut() {
            t.text(value)?;
        }
        if let Some(t) = self.parquet.as_mut() {
            t.text(value).inspect_err(|_| self.parquet_failed = true)?;
        }
        Ok(())
    }

    /// Ends the row, in every format even when one fails (a CSV write that fails on a full
    /// disk must not leave the Parquet row open, or closing it would drop its buffered rows).
    pub fn end_row(&mut self) -> std::io::Result<()> {
        let csv = self.csv.as_mut().map_or(Ok(()), CsvTable::end_row);
        let parquet = match self.parquet.as_mut() {
            Some(t) => t.end_row().inspect_err(|_| self.parquet_failed = true),
            None => Ok(()),
        };
        csv.and(parquet)
    }

    /// Pushes buffered rows to the files (CSV: whole rows; Parquet: the current row group).
    pub fn flush(&mut self) -> Result<(), (PathBuf, std::io::Error)> {
        if let Some(t) = self.csv.as_mut() {
            t.flush().map_err(|e| (t.path().to_path_buf(), e))?;
        }
        if let Some(t) = self.parquet.as_mut() {
            t.flush().map_err(|e| (t.path().to_path_buf(), e))?;
        }
        Ok(())
    }

    /// Closes every file (Parquet: writes the footer), each even when another fails. Returns
    /// (file name, rows) per file — the whole rows each file holds, exact also after a failure
    /// (see [`CsvTable::close`], [`super::ParquetTable`]) — and the first error.
    pub fn finish(self) -> (Vec<(String, u64)>, Option<FileError>) {
        fn file_name(path: &Path) -> String {
            path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
        }
        let mut out = Vec::new();
        let mut error = None;
        if let Some(t) = self.csv {
            let path = t.path().to_path_buf();
            let (rows, result) = t.close();
            out.push((file_name(&path), rows));
            if let Err(e) = result {
                error = Some((path, e));
            }
        }
        if let Some(t) = self.parquet {
            let path = t.path().to_path_buf();
            let (rows, result) = t.close();
            out.push((file_name(&path), rows));
            if let Err(e) = result {
                error = error.or(Some((path, e)));
            }
        }
        (out, error)
    }
}

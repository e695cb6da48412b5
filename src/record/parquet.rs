//! Streaming Parquet tables (feature `parquet`): the same columns as the CSV table, typed
//! (float64, int64, UTF-8 strings), compressed, written one row group at a time.
//!
//! [`ParquetTable`] is one file. Values go into one buffer per column, preallocated for a batch
//! of at most 256 rows (no allocation per value). Every full batch becomes an Arrow record batch
//! that the writer encodes and compresses into the row group in progress; every `row_group_rows`
//! rows the row group goes to the file. `finish` writes the last row group and the footer; a file
//! without its footer (process killed) is not readable.
//!
//! [`ParquetDataset`] is what a run records: a folder `<table>.parquet/` of part files
//! `part-00000.parquet`, … with `rows_per_file` rows each, which pandas, pyarrow, polars and
//! DuckDB read as one table. Two measured reasons (BENCHMARKS.md):
//! - memory: a Parquet writer keeps the metadata of every row group it wrote (the footer, ~0.7 KB
//!   per column chunk, ~0.5 MB per row group of a 10-link snake) until the file is closed, so one
//!   file per table grows with the run; closing a part every `rows_per_file` rows bounds it;
//! - nothing lost: a killed process leaves every closed part readable.
//!
//! A part is written as `.part-00000.parquet.inprogress` and renamed to `part-00000.parquet` once
//! its footer is written and synced. Readers skip the unfinished one: pyarrow's (and so
//! pandas') dataset discovery ignores names starting with `.` or `_`, and a `*.parquet` glob
//! (polars, DuckDB) does not match it. So after SIGKILL, the OOM killer or a full disk,
//! `pd.read_parquet("<run>/links.parquet")` reads every closed part; a part that fails to close
//! is deleted.
//!
//! Compression is LZ4 (raw) by default: ZSTD is 8 % smaller, but arrow-rs creates a ZSTD
//! compression *and* decompression context for every column of every row group (about 0.1 MB
//! each, 75 MB at once for a 10-link snake's 656 columns), which dominates the memory of a run.

use super::format::{ColumnKind, TableSink};
use crate::config::ParquetCompression;
use arrow_array::builder::{ArrayBuilder, StringBuilder};
use arrow_array::{ArrayRef, Float64Array, Int64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema, SchemaRef};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::schema::types::ColumnPath;
use std::fs::File;
use std::io::{BufWriter, Error, ErrorKind};
use std::path::{Path, PathBuf};
use std::sync::Arc;

enum Column {
    Float(Vec<f64>),
    Int(Vec<i64>),
    Text(StringBuilder),
}

impl Column {
    fn new(kind: ColumnKind, capacity: usize) -> Self {
        match kind {
            ColumnKind::Float => Self::Float(Vec::with_capacity(capacity)),
            ColumnKind::Int => Self::Int(Vec::with_capacity(capacity)),
            ColumnKind::Text => Self::Text(StringBuilder::with_capacity(capacity, capacity * 16)),
        }
    }

    fn kind(&self) -> &'static str {
        match self {
            Self::Float(_) => "a number",
            Self::Int(_) => "an integer",
            Self::Text(_) => "text",
        }
    }

    /// Hands the buffered values over as an Arrow array and starts a new buffer.
    fn take(&mut self, capacity: usize) -> ArrayRef {
        match self {
            Self::Float(v) => Arc::new(Float64Array::from(std::mem::replace(v, Vec::with_capacity(capacity)))),
            Self::Int(v) => Arc::new(Int64Array::from(std::mem::replace(v, Vec::with_capacity(capacity)))),
            Self::Text(b) => Arc::new(b.finish()),
        }
    }
}

/// One Parquet file being written.
pub struct ParquetTable {
    path: PathBuf,
    schema: SchemaRef,
    writer: ArrowWriter<BufWriter<File>>,
    columns: Vec<Column>,
    in_row: usize,
    buffered: usize,
    rows: u64,
    batch_rows: usize,
}

fn to_io(e: parquet::errors::ParquetError) -> Error {
    Error::other(e)
}

impl ParquetTable {
    /// Creates the file; `kinds` gives each column's type.
    pub fn create(
        path: &Path,
        header: &[String],
        kinds: &[ColumnKind],
        row_group_rows: usize,
        compression: ParquetCompression,
    ) -> std::io::Result<Self> {
        let row_group_rows = row_group_rows.max(1);
        // 256 rows per Arrow batch (was 1024): the column buffers (656 columns for a 10-link
        // `links` table) take 1.3 MB instead of 5.4 MB. Row groups are cut by row count and, at
        // the default row group size, every column chunk is one page (far below the 1 MB page
        // limit), so the files are byte for byte those written with 1024 (checked for 10 and 30
        // links); only a column chunk above 1 MB (row groups of over ~130,000 rows) could have
        // its pages cut at other rows.
        let batch_rows = row_group_rows.min(256);
        let fields: Vec<Field> = header
            .iter()
            .zip(kinds)
            .map(|(name, kind)| {
                let data_type = match kind {
                    ColumnKind::Float => DataType::Float64,
                    ColumnKind::Int => DataType::Int64,
                    ColumnKind::Text => DataType::Utf8,
                };
                Field::new(name, data_type, false)
            })
            .collect();
        let schema = Arc::new(Schema::new(fields));
        // Dictionaries only pay off for the name columns; floats are nearly all distinct.
        // The writer keeps the metadata of every row group in memory until it writes the footer,
        // so keep that metadata small: no page indexes, and min/max statistics only for the time
        // and step columns (what readers filter on); otherwise memory would grow with the run.
        let mut props = WriterProperties::builder()
            .set_compression(match compression {
                ParquetCompression::Lz4 => Compression::LZ4_RAW,
                ParquetCompression::Zstd => Compression::ZSTD(ZstdLevel::default()),
                ParquetCompression::Snappy => Compression::SNAPPY,
                ParquetCompression::None => Compression::UNCOMPRESSED,
            })
            .set_dictionary_enabled(false)
            .set_statistics_enabled(EnabledStatistics::None)
            .set_offset_index_disabled(true)
            .set_max_row_group_row_count(Some(row_group_rows))
            .set_created_by(format!("simserpent {}", env!("CARGO_PKG_VERSION")));
        for (name, kind) in header.iter().zip(kinds) {
            let column = || ColumnPath::from(name.as_str());
            if *kind == ColumnKind::Text {
                props = props.set_column_dictionary_enabled(column(), true);
            }
            if matches!(name.as_str(), "time_s" | "step") {
                props = props.set_column_statistics_enabled(column(), EnabledStatistics::Chunk);
            }
        }
        let file = File::create(path)?;
        let writer = ArrowWriter::try_new(BufWriter::with_capacity(1 << 16, file), schema.clone(), Some(props.build()))
            .map_err(to_io)?;
        Ok(Self {
            path: path.to_path_buf(),
            schema,
            writer,
            columns: kinds.iter().map(|k| Column::new(*k, batch_rows)).collect(),
            in_row: 0,
            buffered: 0,
            rows: 0,
            batch_rows,
        })
    }

    fn column(&mut self, wanted: &'static str) -> std::io::Result<&mut Column> {
        let i = self.in_row;
        self.in_row += 1;
        let path = &self.path;
        let schema = &self.schema;
        match self.columns.get_mut(i) {
            Some(c) => Ok(c),
            None => Err(Error::new(
                ErrorKind::InvalidData,
                format!("{}: row has more than {} columns (writing {wanted})", path.display(), schema.fields().len()),
            )),
        }
    }

    fn mismatch(&self, wanted: &str, column: &Column) -> Error {
        let name = self.schema.fields().get(self.in_row - 1).map_or("?", |f| f.name().as_str());
        Error::new(
            ErrorKind::InvalidData,
            format!("{}: column `{name}` holds {}, not {wanted}", self.path.display(), column.kind()),
        )
    }

    /// Hands the buffered rows to the encoder (which writes a row group whenever it has
    /// `row_group_rows` rows).
    fn write_batch(&mut self) -> std::io::Result<()> {
        if self.buffered == 0 {
            return Ok(());
        }
        let capacity = self.batch_rows;
        let arrays: Vec<ArrayRef> = self.columns.iter_mut().map(|c| c.take(capacity)).collect();
        let batch = RecordBatch::try_new(self.schema.clone(), arrays).map_err(Error::other)?;
        self.writer.write(&batch).map_err(to_io)?;
        self.buffered = 0;
        Ok(())
    }

    /// Writes the last row group and the footer, and syncs the file to disk.
    pub fn finish(self) -> std::io::Result<()> {
        self.finish_counted().map(|_| ())
    }

    /// [`ParquetTable::finish`], returning the rows the file holds (fewer than [`TableSink::rows`]
    /// when a row was left half-written by an error and its unfinished batch had to be dropped).
    fn finish_counted(mut self) -> std::io::Result<u64> {
        if self.in_row != 0 {
            // A half-written row (an error mid-row): drop it rather than write a ragged table.
            for c in &mut self.columns {
                match c {
                    Column::Float(v) if v.len() > self.buffered => v.truncate(self.buffered),
                    Column::Int(v) if v.len() > self.buffered => v.truncate(self.buffered),
                    _ => {}
                }
            }
            self.in_row = 0;
            if self.columns.iter().any(|c| matches!(c, Column::Text(b) if b.len() > self.buffered)) {
                // Text builders cannot be truncated; drop the whole unfinished row group instead
                // of writing a ragged one.
                self.rows -= self.buffered as u64;
                self.buffered = 0;
                let capacity = self.batch_rows;
                for c in &mut self.columns {
                    let _ = c.take(capacity);
                }
            }
        }
        self.write_batch()?;
        let rows = self.rows;
        let file = self.writer.into_inner().map_err(to_io)?;
        let file = file.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        Ok(rows)
    }
}

impl TableSink for ParquetTable {
    #[inline]
    fn num(&mut self, value: f64) -> std::io::Result<()> {
        match self.column("a number")? {
            Column::Float(v) => {
                v.push(value);
                Ok(())
            }
            _ => {
                let c = &self.columns[self.in_row - 1];
                Err(self.mismatch("a number", c))
            }
        }
    }

    fn int(&mut self, value: u64) -> std::io::Result<()> {
        match self.column("an integer")? {
            Column::Int(v) => {
                v.push(i64::try_from(value).unwrap_or(i64::MAX));
                Ok(())
            }
            Column::Float(v) => {
                v.push(value as f64);
                Ok(())
            }
            Column::Text(_) => {
                let c = &self.columns[self.in_row - 1];
                Err(self.mismatch("an integer", c))
            }
        }
    }

    fn text(&mut self, value: &str) -> std::io::Result<()> {
        match self.column("text")? {
            Column::Text(b) => {
                b.append_value(value);
                Ok(())
            }
            _ => {
                let c = &self.columns[self.in_row - 1];
                Err(self.mismatch("text", c))
            }
        }
    }

    fn end_row(&mut self) -> std::io::Result<()> {
        if self.in_row != self.columns.len() {
            return Err(Error::new(
                ErrorKind::InvalidData,
                format!("{}: row has {} of {} columns", self.path.display(), self.in_row, self.columns.len()),
            ));
        }
        self.in_row = 0;
        self.buffered += 1;
        self.rows += 1;
        if self.buffered >= self.batch_rows { self.write_batch() } else { Ok(()) }
    }

    /// Writes the rows buffered so far as a (possibly short) row group. Whole row groups only
    /// become readable with the footer that `finish` writes.
    fn flush(&mut self) -> std::io::Result<()> {
        if self.in_row == 0 {
            self.write_batch()?;
            self.writer.flush().map_err(to_io)?;
        }
        Ok(())
    }

    fn path(&self) -> &Path {
        &self.path
    }

    fn rows(&self) -> u64 {
        self.rows
    }
}

/// A table recorded as a folder of Parquet part files (see the module documentation).
pub struct ParquetDataset {
    dir: PathBuf,
    header: Vec<String>,
    kinds: Vec<ColumnKind>,
    row_group_rows: usize,
    rows_per_file: u64,
    compression: ParquetCompression,
    /// The part being written; opened at the first value of its first row.
    part: Option<ParquetTable>,
    parts_closed: usize,
    rows: u64,
    /// Rows in the closed (renamed) parts.
    rows_closed: u64,
}

impl ParquetDataset {
    /// Creates the folder `dir` (it must not exist yet); parts are created as rows arrive.
    pub fn create(
        dir: &Path,
        header: &[String],
        kinds: &[ColumnKind],
        row_group_rows: usize,
        rows_per_file: u64,
        compression: ParquetCompression,
    ) -> std::io::Result<Self> {
        std::fs::create_dir(dir)?;
        Ok(Self {
            dir: dir.to_path_buf(),
            header: header.to_vec(),
            kinds: kinds.to_vec(),
            row_group_rows,
            rows_per_file: rows_per_file.max(1),
            compression,
            part: None,
            parts_closed: 0,
            rows: 0,
            rows_closed: 0,
        })
    }

    /// The part file number `index`.
    pub fn part_path(dir: &Path, index: usize) -> PathBuf {
        dir.join(format!("part-{index:05}.parquet"))
    }

    /// Part number `index` while it is written (a name readers skip).
    pub fn part_in_progress_path(dir: &Path, index: usize) -> PathBuf {
        dir.join(format!(".part-{index:05}.parquet.inprogress"))
    }

    /// The part being written, opened if needed (once per `rows_per_file` rows, not per value).
    #[inline]
    fn part(&mut self) -> std::io::Result<&mut ParquetTable> {
        if self.part.is_none() {
            let path = Self::part_in_progress_path(&self.dir, self.parts_closed);
            self.part =
                Some(ParquetTable::create(&path, &self.header, &self.kinds, self.row_group_rows, self.compression)?);
        }
        // Just set when it was empty.
        self.part.as_mut().ok_or_else(|| Error::other("no part file"))
    }

    /// Writes the footer of the part in progress, syncs it and gives it its final name; a part
    /// that fails to close is deleted (the closed parts stay readable).
    fn close_part(&mut self) -> std::io::Result<()> {
        if let Some(part) = self.part.take() {
            let unfinished = part.path.clone();
            let done = Self::part_path(&self.dir, self.parts_closed);
            let result = part.finish_counted().and_then(|rows| std::fs::rename(&unfinished, &done).map(|()| rows));
            match result {
                Ok(rows) => {
                    self.parts_closed += 1;
                    self.rows_closed += rows;
                }
                Err(e) => {
                    let _ = std::fs::remove_file(&unfinished);
                    return Err(e);
                }
            }
        }
        Ok(())
    }

    /// Closes the last part (a table without rows still gets one, empty, so that readers find
    /// its columns); returns the rows of the closed parts (all rows, unless it failed) and the
    /// result. A part in progress that cannot be
    /// closed is deleted, and the folder is synced, so the parts it lists are the rows counted.
    pub fn close(mut self) -> (u64, std::io::Result<()>) {
        let mut result = Ok(());
        if self.part.is_none() && self.parts_closed == 0 {
            result = self.part().map(|_| ());
        }
        if result.is_ok() {
            result = self.close_part();
        } else if let Some(part) = self.part.take() {
            let _ = std::fs::remove_file(&part.path);
        }
        // The renames reach the disk with the folder's own sync.
        if let Ok(dir) = File::open(&self.dir) {
            let _ = dir.sync_all();
        }
        (self.rows_closed, result)
    }
}

impl TableSink for ParquetDataset {
    #[inline]
    fn num(&mut self, value: f64) -> std::io::Result<()> {
        self.part()?.num(value)
    }

    /// One look-up of the part for a group of numbers.
    #[inline]
    fn nums(&mut self, values: &[f64]) -> std::io::Result<()> {
        let part = self.part()?;
        values.iter().try_for_each(|v| part.num(*v))
    }

    #[inline]
    fn int(&mut self, value: u64) -> std::io::Result<()> {
        self.part()?.int(value)
    }

    #[inline]
    fn text(&mut self, value: &str) -> std::io::Result<()> {
        self.part()?.text(value)
    }

    fn end_row(&mut self) -> std::io::Result<()> {
        let part = self.part()?;
        part.end_row()?;
        let full = part.rows() >= self.rows_per_file;
        self.rows += 1;
        if full { self.close_part() } else { Ok(()) }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self.part.as_mut() {
            Some(part) => part.flush(),
            None => Ok(()),
        }
    }

    fn path(&self) -> &Path {
        &self.dir
    }

    fn rows(&self) -> u64 {
        self.rows
    }
}

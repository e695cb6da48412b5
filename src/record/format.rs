//! The interface of a table file format: a [`TableSink`] takes one row at a time, value by value,
//! in columns of a [`ColumnKind`]. CSV (`table`) and Parquet (`parquet`) implement it; `sink`
//! fans each value out to the formats a run asks for.

use std::path::Path;

/// The type of a column. CSV writes all of them as text; Parquet stores them typed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnKind {
    /// 64-bit float (`num`).
    Float,
    /// Integer (`int`; signed 64-bit in Parquet, which every reader handles).
    Int,
    /// Text (`text`; UTF-8 string in Parquet).
    Text,
}

/// A streaming table in one file format. A row is a sequence of `num`/`int`/`text` calls in
/// column order, closed by `end_row`. No call allocates per value (buffers grow only when a
/// row group is handed to the encoder).
pub trait TableSink {
    /// Appends a number to the current row.
    fn num(&mut self, value: f64) -> std::io::Result<()>;
    /// Appends several numbers.
    fn nums(&mut self, values: &[f64]) -> std::io::Result<()> {
        values.iter().try_for_each(|v| self.num(*v))
    }
    /// Appends an integer.
    fn int(&mut self, value: u64) -> std::io::Result<()>;
    /// Appends a name.
    fn text(&mut self, value: &str) -> std::io::Result<()>;
    /// Ends the row.
    fn end_row(&mut self) -> std::io::Result<()>;
    /// Pushes buffered rows toward the file.
    fn flush(&mut self) -> std::io::Result<()>;
    /// The file.
    fn path(&self) -> &Path;
    /// Rows written so far.
    fn rows(&self) -> u64;
}

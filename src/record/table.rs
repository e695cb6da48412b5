//! A streaming CSV table: header first, then one row per recorded step, written through a
//! buffer. Numbers are written with `ryu` (shortest representation that round-trips, no
//! allocation); names are plain identifiers, so nothing needs quoting.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// One CSV file being written.
pub struct CsvTable {
    path: PathBuf,
    out: BufWriter<File>,
    columns: usize,
    in_row: usize,
    rows: u64,
    number: ryu::Buffer,
}

impl CsvTable {
    /// Creates the file and writes the header.
    pub fn create(path: &Path, header: &[String]) -> std::io::Result<Self> {
        let file = File::create(path)?;
        let mut out = BufWriter::with_capacity(1 << 16, file);
        out.write_all(header.join(",").as_bytes())?;
        out.write_all(b"\n")?;
        Ok(Self {
            path: path.to_path_buf(),
            out,
            columns: header.len(),
            in_row: 0,
            rows: 0,
            number: ryu::Buffer::new(),
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    fn separator(&mut self) -> std::io::Result<()> {
        if self.in_row > 0 {
            self.out.write_all(b",")?;
        }
        self.in_row += 1;
        Ok(())
    }

    /// Appends a number to the current row.
    pub fn num(&mut self, value: f64) -> std::io::Result<()> {
        self.separator()?;
        if value.is_finite() {
            let text = self.number.format_finite(value);
            self.out.write_all(text.as_bytes())
        } else if value.is_nan() {
            self.out.write_all(b"nan")
        } else if value > 0.0 {
            self.out.write_all(b"inf")
        } else {
            self.out.write_all(b"-inf")
        }
    }

    /// Appends several numbers.
    pub fn nums(&mut self, values: &[f64]) -> std::io::Result<()> {
        values.iter().try_for_each(|v| self.num(*v))
    }

    /// Appends an integer.
    pub fn int(&mut self, value: u64) -> std::io::Result<()> {
        self.separator()?;
        let mut buf = itoa::Buffer::new();
        self.out.write_all(buf.format(value).as_bytes())
    }

    /// Appends a name (an identifier; must not contain commas, quotes or newlines).
    pub fn text(&mut self, value: &str) -> std::io::Result<()> {
        self.separator()?;
        self.out.write_all(value.as_bytes())
    }

    /// Ends the row. Panics in debug builds if the row has the wrong number of fields.
    pub fn end_row(&mut self) -> std::io::Result<()> {
        debug_assert_eq!(self.in_row, self.columns, "{}: row width", self.path.display());
        self.in_row = 0;
        self.rows += 1;
        self.out.write_all(b"\n")
    }

    /// Pushes buffered rows to the file (so that readers see whole rows).
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }

    /// Flushes and syncs the file to disk.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()?;
        self.out.get_ref().sync_all()
    }
}

//! The summary table: one row per run, every column typed from the start (an integer, a number
//! or text), written as `summary.csv` and, with the `parquet` feature, `summary.parquet` from
//! the same typed cells.
//!
//! Columns: `run_index` (integer), `run_id` (text), one per varied key, `status`, `error`,
//! `run_folder` (text), the [`METRICS`] and `wall_secs` (numbers). A parameter column is an
//! integer column when every value is a non-negative TOML integer, a number column when every
//! value is a TOML integer or float, and text otherwise (strings, booleans, arrays).

use super::plan::{PlannedRun, plain};
use super::spec::{SweepSpec, Variation, number, parse_value};
use super::{SweepError, io_error};
use crate::run::RunSummary;
use std::path::{Path, PathBuf};
use toml::Value;

/// What happened to a run.
#[derive(Debug, Clone, PartialEq)]
pub enum RunOutcome {
    /// Ran now and completed.
    Complete(RunSummary),
    /// Completed in an earlier invocation; the summary was read from its manifest.
    Skipped(SkippedSummary),
    /// Failed (also: invalid parameter combination); the message says why.
    Failed(String),
    /// Stopped by SIGINT/SIGTERM ([`crate::interrupt`]), or not started because of one; redone
    /// by the next invocation.
    Interrupted(String),
}

/// A run finished earlier, read back from its `manifest.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedSummary {
    /// Its summary as the manifest holds it (`None` if the manifest has none).
    pub summary: Option<RunSummary>,
    /// Wall time of that run (s).
    pub wall_secs: f64,
}

/// One row of the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// The plan entry.
    pub run: PlannedRun,
    /// Its outcome.
    pub outcome: RunOutcome,
    /// Its folder.
    pub folder: PathBuf,
    /// Wall seconds this invocation spent on it (0 for skipped).
    pub wall_secs: f64,
}

/// One metric of a run: a summary column.
#[derive(Debug, Clone, Copy)]
pub struct Metric {
    /// Column name (the [`RunSummary`] field; it ends in the unit).
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// What it is.
    pub doc: &'static str,
    /// Its value in a run's summary.
    pub value: fn(&RunSummary) -> f64,
}

/// The metrics of a run in the summary, in column order: the one list of them (the Python
/// package's `SWEEP_METRICS` and run summaries come from it too).
pub const METRICS: &[Metric] = &[
    Metric { name: "simulated_secs", unit: "s", doc: "simulated time", value: |s| s.simulated_secs },
    Metric {
        name: "distance_m",
        unit: "m",
        doc: "horizontal displacement of the centre of mass",
        value: |s| s.distance_m,
    },
    Metric {
        name: "mean_speed_m_per_s",
        unit: "m/s",
        doc: "distance over simulated time",
        value: |s| s.mean_speed_m_per_s,
    },
    Metric {
        name: "forward_speed_m_per_s",
        unit: "m/s",
        doc: "speed along the direction the head faced at the start",
        value: |s| s.forward_speed_m_per_s,
    },
    Metric {
        name: "heading_deg",
        unit: "deg",
        doc: "direction of the displacement in the xy-plane, from +x",
        value: |s| s.heading_deg,
    },
    Metric {
        name: "peak_contact_force_10ms_n",
        unit: "N",
        doc: "largest contact normal force on one link averaged over 10 ms (its normal impulse over any 10-ms window / \
              10 ms; every step)",
        value: |s| s.peak_contact_force_10ms_n,
    },
    Metric {
        name: "peak_contact_force_step_n",
        unit: "N",
        doc: "largest single contact normal force at any step (depends on the timestep)",
        value: |s| s.peak_contact_force_step_n,
    },
    Metric {
        name: "max_penetration_m",
        unit: "m",
        doc: "largest penetration at a recorded step",
        value: |s| s.max_penetration_m,
    },
    Metric { name: "actuator_energy_j", unit: "J", doc: "work done by the actuators", value: |s| s.actuator_energy_j },
    Metric {
        name: "steps_per_wall_sec",
        unit: "1/s",
        doc: "physics steps per second of wall time",
        value: |s| s.steps_per_wall_sec,
    },
];

/// The type of a summary column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnType {
    /// Non-negative integers (Parquet int64).
    Int,
    /// Numbers; missing ones are empty in the CSV and NaN in Parquet (float64).
    Float,
    /// Text (Parquet UTF-8).
    Text,
}

/// A summary column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Column {
    /// Its name (the CSV header).
    pub name: String,
    /// Its type.
    pub kind: ColumnType,
}

impl Column {
    fn new(name: impl Into<String>, kind: ColumnType) -> Self {
        Self { name: name.into(), kind }
    }
}

/// A column compares equal to its name.
impl PartialEq<str> for Column {
    fn eq(&self, name: &str) -> bool {
        self.name == name
    }
}

impl PartialEq<&str> for Column {
    fn eq(&self, name: &&str) -> bool {
        self.name == *name
    }
}

/// The value of a cell, of its column's type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CellValue {
    /// In an integer column.
    Int(u64),
    /// In a number column (NaN: missing).
    Float(f64),
    /// In a text column: the cell's text.
    Text,
}

/// One cell: its typed value and its CSV text, made from the value (integers in decimal,
/// numbers as their shortest round-trip text or empty when missing, parameters as the TOML
/// literal without string quotes), or kept as read from a CSV.
#[derive(Debug, Clone)]
pub struct Cell {
    value: CellValue,
    text: String,
}

impl Cell {
    /// An integer.
    pub fn int(n: u64) -> Self {
        Self { value: CellValue::Int(n), text: itoa::Buffer::new().format(n).to_string() }
    }

    /// A number; a non-finite one is missing.
    pub fn float(x: f64) -> Self {
        if x.is_finite() {
            Self { value: CellValue::Float(x), text: zmij::Buffer::new().format_finite(x).to_string() }
        } else {
            Self { value: CellValue::Float(f64::NAN), text: String::new() }
        }
    }

    /// Text.
    pub fn text(text: impl Into<String>) -> Self {
        Self { value: CellValue::Text, text: text.into() }
    }

    /// A parameter value written as `text`, in a column of type `kind` (see [`param_kind`]);
    /// `None` when the value is not of that type.
    fn param(value: &Value, text: String, kind: ColumnType) -> Option<Self> {
        let value = match (kind, value) {
            (ColumnType::Int, Value::Integer(i)) => CellValue::Int(u64::try_from(*i).ok()?),
            (ColumnType::Float, v) => CellValue::Float(number(v)?),
            (ColumnType::Text, _) => CellValue::Text,
            (ColumnType::Int, _) => return None,
        };
        Some(Self { value, text })
    }

    /// A cell of a column of type `kind` read from its CSV text; `None` when the text is not of
    /// that type.
    fn parse(text: String, kind: ColumnType) -> Option<Self> {
        let value = match kind {
            ColumnType::Int => CellValue::Int(text.parse().ok()?),
            ColumnType::Float if text.is_empty() => CellValue::Float(f64::NAN),
            ColumnType::Float => CellValue::Float(text.parse().ok()?),
            ColumnType::Text => CellValue::Text,
        };
        Some(Self { value, text })
    }

    /// The typed value.
    pub fn value(&self) -> CellValue {
        self.value
    }

    /// The CSV text.
    pub fn as_str(&self) -> &str {
        &self.text
    }
}

/// Cells are equal when their texts and types are (a missing number equals a missing number).
impl PartialEq for Cell {
    fn eq(&self, other: &Self) -> bool {
        self.text == other.text && std::mem::discriminant(&self.value) == std::mem::discriminant(&other.value)
    }
}

impl PartialEq<&str> for Cell {
    fn eq(&self, text: &&str) -> bool {
        self.text == *text
    }
}

/// The type of a parameter column with these values: integers when all are non-negative TOML
/// integers, numbers when all are TOML integers or floats, text otherwise; numbers when there
/// are no values.
fn param_kind<'a>(values: impl IntoIterator<Item = &'a Value>) -> ColumnType {
    let mut values = values.into_iter().peekable();
    if values.peek().is_none() {
        return ColumnType::Float;
    }
    let mut kind = ColumnType::Int;
    for value in values {
        match value {
            Value::Integer(i) if *i >= 0 => {}
            Value::Integer(_) | Value::Float(_) => kind = ColumnType::Float,
            _ => return ColumnType::Text,
        }
    }
    kind
}

/// The type of a column by its name, for the columns that are not parameters.
fn fixed_kind(name: &str) -> Option<ColumnType> {
    match name {
        "run_index" => Some(ColumnType::Int),
        "run_id" | "status" | "error" | "run_folder" => Some(ColumnType::Text),
        "wall_secs" => Some(ColumnType::Float),
        _ => METRICS.iter().any(|m| m.name == name).then_some(ColumnType::Float),
    }
}

/// The summary of a sweep: typed columns and their cells.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryTable {
    /// The columns.
    pub header: Vec<Column>,
    /// Rows of cells, one per column.
    pub rows: Vec<Vec<Cell>>,
}

impl SummaryTable {
    /// The summary of `rows` (columns: index, id, the varied keys, status, error, folder,
    /// [`METRICS`], `wall_secs`).
    pub fn from_rows(variations: &[Variation], rows: &[SweepRow]) -> Self {
        let mut header = vec![Column::new("run_index", ColumnType::Int), Column::new("run_id", ColumnType::Text)];
        header.extend(variations.iter().enumerate().map(|(k, v)| {
            let kind = param_kind(rows.iter().filter_map(|r| r.run.params.get(k)).map(|(_, value)| value));
            Column::new(v.key.clone(), kind)
        }));
        header.extend(["status", "error", "run_folder"].map(|name| Column::new(name, ColumnType::Text)));
        header.extend(METRICS.iter().map(|m| Column::new(m.name, ColumnType::Float)));
        header.push(Column::new("wall_secs", ColumnType::Float));
        let rows = rows
            .iter()
            .map(|r| {
                let mut cells = vec![Cell::int(r.run.index as u64), Cell::text(r.run.id.clone())];
                cells.extend(r.run.params.iter().zip(&header[2..]).map(|((_, value), column)| {
                    let text = plain(value);
                    Cell::param(value, text.clone(), column.kind).unwrap_or_else(|| Cell::text(text))
                }));
                let (status, error, summary, wall_secs) = match &r.outcome {
                    RunOutcome::Complete(s) => ("complete", "", Some(s), r.wall_secs),
                    RunOutcome::Skipped(s) => ("complete", "", s.summary.as_ref(), s.wall_secs),
                    RunOutcome::Failed(e) => ("failed", e.as_str(), None, r.wall_secs),
                    RunOutcome::Interrupted(e) => ("incomplete", e.as_str(), None, r.wall_secs),
                };
                cells.extend([Cell::text(status), Cell::text(error), Cell::text(format!("runs/{}", r.run.id))]);
                cells.extend(METRICS.iter().map(|m| Cell::float(summary.map_or(f64::NAN, m.value))));
                cells.push(Cell::float(wall_secs));
                cells
            })
            .collect();
        Self { header, rows }
    }

    /// The table of a header and rows of CSV cells (as [`SummaryTable::write_csv`] writes
    /// them; the Python package's Ray sweep passes rows as text). Parameters are read as
    /// `--vary` reads values: TOML literals, or bare words as strings.
    ///
    /// `None` when the first column is not `run_index`, a row has another length than the
    /// header, or a cell is not of its column's type.
    pub fn from_text(header: Vec<String>, rows: Vec<Vec<String>>) -> Option<Self> {
        if header.first().map(String::as_str) != Some("run_index") || rows.iter().any(|r| r.len() != header.len()) {
            return None;
        }
        let header: Vec<Column> = header
            .into_iter()
            .enumerate()
            .map(|(i, name)| {
                let kind = fixed_kind(&name)
                    .unwrap_or_else(|| param_kind(rows.iter().map(|r| parse_value(&r[i])).collect::<Vec<_>>().iter()));
                Column { name, kind }
            })
            .collect();
        let rows = rows
            .into_iter()
            .map(|row| {
                row.into_iter()
                    .zip(&header)
                    .map(|(text, column)| match fixed_kind(&column.name) {
                        Some(kind) => Cell::parse(text, kind),
                        None => Cell::param(&parse_value(&text), text, column.kind),
                    })
                    .collect::<Option<Vec<Cell>>>()
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Self { header, rows })
    }

    /// The column names.
    pub fn names(&self) -> Vec<String> {
        self.header.iter().map(|c| c.name.clone()).collect()
    }

    /// Writes the CSV (RFC 4180 quoting for cells with commas, quotes or newlines).
    ///
    /// # Errors
    /// [`SweepError::Io`].
    pub fn write_csv(&self, path: &Path) -> Result<(), SweepError> {
        let mut text = String::new();
        let header = self.header.iter().map(|c| c.name.as_str());
        for row in std::iter::once(header.collect::<Vec<_>>())
            .chain(self.rows.iter().map(|r| r.iter().map(Cell::as_str).collect()))
        {
            let cells: Vec<String> = row.iter().map(|c| quote(c)).collect();
            text.push_str(&cells.join(","));
            text.push('\n');
        }
        // Never through a link planted at the summary's name ([`crate::files`]' writer rule).
        let mut file = crate::files::open_for_writing(path, false)?;
        std::io::Write::write_all(&mut file, text.as_bytes()).map_err(io_error(path))
    }

    /// Reads a CSV written by [`SummaryTable::write_csv`].
    ///
    /// # Errors
    /// [`SweepError::Io`] when the file cannot be read, [`SweepError::EmptyFile`],
    /// [`SweepError::NotASummary`].
    pub fn read_csv(path: &Path) -> Result<Self, SweepError> {
        let (header, rows) = read_cells(path)?;
        Self::from_text(header, rows).ok_or_else(|| SweepError::NotASummary { path: path.to_path_buf() })
    }

    /// Writes the Parquet twin: each column of its type (int64, float64 with NaN for missing
    /// numbers, UTF-8).
    ///
    /// # Errors
    /// [`SweepError::Io`].
    #[cfg(feature = "parquet")]
    pub fn write_parquet(&self, path: &Path) -> Result<(), SweepError> {
        use crate::record::{ColumnKind, ParquetTable, TableSink};
        let err = io_error(path);
        let names = self.names();
        let kinds: Vec<ColumnKind> = self
            .header
            .iter()
            .map(|c| match c.kind {
                ColumnType::Int => ColumnKind::Int,
                ColumnType::Float => ColumnKind::Float,
                ColumnType::Text => ColumnKind::Text,
            })
            .collect();
        let written = (|| {
            let mut table =
                ParquetTable::create(path, &names, &kinds, 10_000, crate::config::ParquetCompression::Zstd)?;
            for row in &self.rows {
                for cell in row {
                    match cell.value {
                        CellValue::Int(n) => table.int(n),
                        CellValue::Float(x) => table.num(x),
                        CellValue::Text => table.text(&cell.text),
                    }?;
                }
                table.end_row()?;
            }
            table.finish()
        })();
        written.map_err(err)
    }
}

/// Reads the header and rows of a CSV as text.
fn read_cells(path: &Path) -> Result<(Vec<String>, Vec<Vec<String>>), SweepError> {
    // A regular file inside its sweep folder, at most 64 MiB ([`crate::files`]' reader).
    let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let text = crate::files::read_text_in(folder, path, crate::files::SMALL_FILE_CAP_BYTES)?;
    let mut records = parse_csv(&text).into_iter();
    let header = records.next().ok_or_else(|| SweepError::EmptyFile { path: path.to_path_buf() })?;
    Ok((header, records.collect()))
}

/// Writes `summary.csv` (and `summary.parquet` with the `parquet` feature), or
/// `summary-shard-i-of-n.*` for a shard, into `sweep_dir`; returns the CSV's path.
///
/// # Errors
/// [`SweepError::Io`].
pub fn write_summary(spec: &SweepSpec, sweep_dir: &Path, table: &SummaryTable) -> Result<PathBuf, SweepError> {
    let name = match spec.shard {
        Some(s) => format!("summary-shard-{}-of-{}", s.index, s.count),
        None => "summary".to_string(),
    };
    let summary_csv = sweep_dir.join(format!("{name}.csv"));
    table.write_csv(&summary_csv)?;
    #[cfg(feature = "parquet")]
    table.write_parquet(&sweep_dir.join(format!("{name}.parquet")))?;
    Ok(summary_csv)
}

fn quote(cell: &str) -> String {
    if cell.contains([',', '"', '\n', '\r']) { format!("\"{}\"", cell.replace('"', "\"\"")) } else { cell.to_string() }
}

fn parse_csv(text: &str) -> Vec<Vec<String>> {
    let (mut records, mut record, mut field) = (Vec::new(), Vec::new(), String::new());
    let (mut in_quotes, mut chars) = (false, text.chars().peekable());
    while let Some(c) = chars.next() {
        match (in_quotes, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            (true, '"') => in_quotes = false,
            (true, c) => field.push(c),
            (false, '"') => in_quotes = true,
            (false, ',') => record.push(std::mem::take(&mut field)),
            (false, '\r') => {}
            (false, '\n') => {
                record.push(std::mem::take(&mut field));
                records.push(std::mem::take(&mut record));
            }
            (false, c) => field.push(c),
        }
    }
    if !field.is_empty() || !record.is_empty() {
        record.push(field);
        records.push(record);
    }
    records
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quoting_round_trips() {
        let cells = ["plain", "a,b", "say \"hi\"", "line\nbreak", ""];
        let line: Vec<String> = cells.iter().map(|c| quote(c)).collect();
        let parsed = parse_csv(&(line.join(",") + "\n"));
        assert_eq!(parsed, vec![cells.map(String::from).to_vec()]);
    }

    #[test]
    fn parameter_columns_have_the_type_of_their_values() {
        let kind = |values: &[Value]| param_kind(values);
        assert_eq!(kind(&[Value::Integer(5), Value::Integer(10)]), ColumnType::Int);
        assert_eq!(kind(&[Value::Integer(-1), Value::Integer(2)]), ColumnType::Float, "int64 holds no negatives");
        assert_eq!(kind(&[Value::Integer(1), Value::Float(2.5)]), ColumnType::Float);
        assert_eq!(kind(&[Value::String("torque".into())]), ColumnType::Text);
        assert_eq!(kind(&[Value::Boolean(true)]), ColumnType::Text);
        assert_eq!(kind(&[]), ColumnType::Float);
    }

    #[test]
    fn text_rows_become_typed_cells_and_keep_their_text() {
        let header = ["run_index", "run_id", "a.b", "c.d", "status", "error", "run_folder", "distance_m", "wall_secs"];
        let rows = [
            ["0", "x", "1", "1.0", "complete", "", "runs/x", "", "0.5"],
            ["1", "y", "-2", "true", "failed", "e, f", "runs/y", "1e-7", "1"],
        ];
        let table = SummaryTable::from_text(
            header.map(String::from).to_vec(),
            rows.iter().map(|r| r.map(String::from).to_vec()).collect(),
        )
        .expect("a summary");
        let kinds: Vec<ColumnType> = table.header.iter().map(|c| c.kind).collect();
        use ColumnType::{Float, Int, Text};
        assert_eq!(kinds, [Int, Text, Float, Text, Text, Text, Text, Float, Float]);
        assert_eq!(table.rows[0][2].value(), CellValue::Float(1.0));
        assert_eq!(table.rows[1][7].value(), CellValue::Float(1e-7));
        assert!(matches!(table.rows[0][7].value(), CellValue::Float(x) if x.is_nan()));
        for (row, cells) in table.rows.iter().zip(&rows) {
            assert_eq!(row.iter().map(Cell::as_str).collect::<Vec<_>>(), cells);
        }
        let bad = |header: &[&str], row: &[&str]| {
            SummaryTable::from_text(
                header.iter().map(|s| s.to_string()).collect(),
                vec![row.iter().map(|s| s.to_string()).collect()],
            )
        };
        assert!(bad(&["run_id"], &["x"]).is_none(), "first column not run_index");
        assert!(bad(&["run_index", "run_id"], &["0"]).is_none(), "short row");
        assert!(bad(&["run_index", "run_id"], &["zero", "x"]).is_none(), "index not an integer");
        assert!(bad(&["run_index", "distance_m"], &["0", "far"]).is_none(), "metric not a number");
    }

    #[test]
    fn each_metric_is_the_run_summary_field_of_its_name() {
        let summary = RunSummary {
            run_folder: PathBuf::from("runs/x"),
            simulated_secs: 1.0,
            distance_m: 2.0,
            mean_speed_m_per_s: 3.0,
            heading_deg: 4.0,
            forward_speed_m_per_s: 5.0,
            peak_contact_force_10ms_n: 6.0,
            contact_force_window_secs: 0.01,
            peak_contact_force_step_n: 6.5,
            max_penetration_m: 7.0,
            actuator_energy_j: 8.0,
            obstacle_contact_secs: 0.0,
            start_sink_m: 0.0,
            tracking: None,
            notes: Vec::new(),
            steps_per_wall_sec: 9.0,
            real_time_factor: 10.0,
            loop_cpu_secs: 11.0,
        };
        let json = serde_json::to_value(&summary).expect("serialisable");
        for metric in METRICS {
            assert_eq!(json[metric.name].as_f64(), Some((metric.value)(&summary)), "{}", metric.name);
        }
    }

    #[test]
    fn missing_numbers_are_empty_and_equal() {
        assert_eq!(Cell::float(f64::NAN).as_str(), "");
        assert_eq!(Cell::float(f64::INFINITY), Cell::float(f64::NAN));
        assert_eq!(Cell::float(0.1).as_str(), "0.1");
        assert_eq!(Cell::int(42).as_str(), "42");
    }
}

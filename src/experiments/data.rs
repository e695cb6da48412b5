//! Reading a run's CSV tables back for analysis, through [`crate::files`]' reader (a regular
//! file inside the run folder, at most [`crate::files::TABLE_CAP_BYTES`]).

use super::ExperimentError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A CSV table as columns: numbers (NaN where a field is not a number) and the raw text of
/// text columns (those whose first row is not a number).
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// The file read.
    pub path: PathBuf,
    /// Column names in file order.
    pub header: Vec<String>,
    numbers: Vec<Vec<f64>>,
    text: Vec<Option<Vec<String>>>,
    /// Per column, the first field that is not a usable number: (row, text, why).
    refused: Vec<Option<(usize, String, &'static str)>>,
    index: HashMap<String, usize>,
}

impl Table {
    /// Reads `path`, a table inside the folder that holds it (a link out of that folder, a FIFO,
    /// a device or an oversized file is refused). Every row must have the header's number of
    /// fields, but for a half-written last line (a killed run), which is dropped.
    pub fn read(path: &Path) -> Result<Self, ExperimentError> {
        let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let content = crate::files::read_text_in(folder, path, crate::files::TABLE_CAP_BYTES)?;
        let bad = |message: String| ExperimentError::Data(format!("{}: {message}", path.display()));
        let mut lines = content.lines();
        let header: Vec<String> =
            lines.next().ok_or_else(|| bad("the file is empty".into()))?.split(',').map(String::from).collect();
        let mut index = HashMap::with_capacity(header.len());
        for (i, h) in header.iter().enumerate() {
            if index.insert(h.clone(), i).is_some() {
                return Err(bad(format!("the column `{h}` appears twice in the header")));
            }
        }
        let lines: Vec<&str> = lines.collect();
        let mut numbers = vec![Vec::with_capacity(lines.len()); header.len()];
        let mut text: Vec<Option<Vec<String>>> = vec![None; header.len()];
        let mut refused = vec![None; header.len()];
        for (r, line) in lines.iter().enumerate() {
            let n_fields = line.split(',').count();
            if n_fields != header.len() {
                if r + 1 == lines.len() {
                    break;
                }
                return Err(bad(format!("row {}: {n_fields} fields, the header has {}", r + 1, header.len())));
            }
            for (c, field) in line.split(',').enumerate() {
                let value = match crate::files::parse_number(field) {
                    Ok(v) => v,
                    Err(why) => {
                        if r == 0 && why == "is not a number" {
                            text[c] = Some(Vec::with_capacity(lines.len()));
                        }
                        if refused[c].is_none() {
                            refused[c] = Some((r + 1, field.chars().take(40).collect(), why));
                        }
                        f64::NAN
                    }
                };
                numbers[c].push(value);
                if let Some(t) = text[c].as_mut() {
                    t.push(field.to_string());
                }
            }
        }
        Ok(Self { path: path.to_path_buf(), header, numbers, text, refused, index })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.numbers.first().map_or(0, Vec::len)
    }

    /// A numeric column (NaN where a field is not a usable number).
    pub fn col(&self, name: &str) -> Result<&[f64], ExperimentError> {
        self.index
            .get(name)
            .map(|&i| self.numbers[i].as_slice())
            .ok_or_else(|| ExperimentError::Data(format!("no column {name}")))
    }

    /// A numeric column whose every field is a finite number within
    /// [`crate::files::MAX_ABS_VALUE`]; `Ok(None)` when there is no such column, and an error
    /// naming the file, row and column otherwise.
    pub fn finite_col(&self, name: &str) -> Result<Option<&[f64]>, String> {
        let Some(&i) = self.index.get(name) else { return Ok(None) };
        match &self.refused[i] {
            None => Ok(Some(self.numbers[i].as_slice())),
            Some((row, text, why)) => Err(format!("row {row}, column `{name}`: {text:?} {why}")),
        }
    }

    /// A text column (one whose first row is not a number).
    pub fn text(&self, name: &str) -> Result<&[String], ExperimentError> {
        let none: &[String] = &[];
        self.index
            .get(name)
            .and_then(|&i| self.text[i].as_deref().or((self.rows() == 0).then_some(none)))
            .ok_or_else(|| ExperimentError::Data(format!("no text column {name}")))
    }
}

//! Reading a run's CSV tables back for analysis.

use super::ExperimentError;
use std::collections::HashMap;
use std::path::Path;

/// A CSV table as columns: numbers (NaN where a field is not a number) and the raw text of
/// non-numeric columns.
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// Column names in file order.
    pub header: Vec<String>,
    numbers: Vec<Vec<f64>>,
    text: Vec<Vec<String>>,
    index: HashMap<String, usize>,
}

impl Table {
    /// Reads `path`.
    pub fn read(path: &Path) -> Result<Self, ExperimentError> {
        let content = std::fs::read_to_string(path).map_err(|source| ExperimentError::Io {
            what: "read",
            path: path.to_path_buf(),
            source,
        })?;
        let mut lines = content.lines();
        let header: Vec<String> = lines.next().unwrap_or_default().split(',').map(String::from).collect();
        let mut numbers = vec![Vec::new(); header.len()];
        let mut text = vec![Vec::new(); header.len()];
        for line in lines {
            for (c, field) in line.split(',').enumerate().take(header.len()) {
                numbers[c].push(field.parse::<f64>().unwrap_or(f64::NAN));
                text[c].push(field.to_string());
            }
        }
        let index = header.iter().enumerate().map(|(i, h)| (h.clone(), i)).collect();
        Ok(Self { header, numbers, text, index })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.numbers.first().map_or(0, Vec::len)
    }

    /// A numeric column.
    pub fn col(&self, name: &str) -> Result<&[f64], ExperimentError> {
        self.index
            .get(name)
            .map(|&i| self.numbers[i].as_slice())
            .ok_or_else(|| ExperimentError::Data(format!("no column {name}")))
    }

    /// A text column.
    pub fn text(&self, name: &str) -> Result<&[String], ExperimentError> {
        self.index
            .get(name)
            .map(|&i| self.text[i].as_slice())
            .ok_or_else(|| ExperimentError::Data(format!("no column {name}")))
    }
}

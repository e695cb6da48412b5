//! Parquet tables (`recording.format`): same columns and values as the CSV tables, typed
//! columns, row groups written as the run goes, readable by the parquet crate (and by
//! pandas/pyarrow when Python has them).
#![allow(clippy::unwrap_used)]

use simserpent::config::{Config, ConfigError, ConfigSource, load_config_str};
use std::path::Path;

fn config(dir: &Path, overrides: &[&str]) -> Result<Config, ConfigError> {
    let mut all: Vec<String> = vec![
        "general.duration_secs=0.5".into(),
        "recording.every_n_steps=5".into(),
        format!("general.output_dir=\"{}\"", dir.join("runs").display()),
    ];
    all.extend(overrides.iter().map(|s| s.to_string()));
    load_config_str(simserpent::config::DEFAULT_CONFIG_TOML, ConfigSource::Toml, &all)
}

#[cfg(not(feature = "parquet"))]
#[test]
fn parquet_without_the_feature_is_a_config_error() {
    let dir = tempfile::tempdir().unwrap();
    for format in ["parquet", "both"] {
        let e = config(dir.path(), &[&format!("recording.format={format}")]).unwrap_err();
        assert!(matches!(&e, ConfigError::InvalidValue { key, .. } if key == "recording.format"), "{e}");
        assert!(e.to_string().contains("feature"), "{e}");
    }
    assert!(config(dir.path(), &["recording.format=csv"]).is_ok());
}

#[cfg(feature = "parquet")]
mod with_parquet {
    use super::*;
    use arrow_array::{Array, Float64Array, Int64Array, RecordBatch, StringArray};
    use arrow_schema::DataType;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    use simserpent::run::{self, RunOptions};

    fn read_parquet(path: &Path) -> (Vec<(String, DataType)>, Vec<RecordBatch>, usize) {
        let file = std::fs::File::open(path).unwrap();
        let builder = ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
        let row_groups = builder.metadata().num_row_groups();
        let fields =
            builder.schema().fields().iter().map(|f| (f.name().clone(), f.data_type().clone())).collect::<Vec<_>>();
        let batches = builder.build().unwrap().collect::<Result<Vec<_>, _>>().unwrap();
        (fields, batches, row_groups)
    }

    fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap().split(',').map(String::from).collect();
        (header, lines.map(|l| l.split(',').map(String::from).collect()).collect())
    }

    /// Cell `row` of column `col` as text, in the CSV's spelling.
    fn cell(batches: &[RecordBatch], col: usize, mut row: usize) -> String {
        for b in batches {
            if row < b.num_rows() {
                let a = b.column(col);
                if let Some(f) = a.as_any().downcast_ref::<Float64Array>() {
                    let v = f.value(row);
                    return if v.is_finite() { ryu::Buffer::new().format_finite(v).to_string() } else { v.to_string() };
                }
                if let Some(i) = a.as_any().downcast_ref::<Int64Array>() {
                    return i.value(row).to_string();
                }
                if let Some(s) = a.as_any().downcast_ref::<StringArray>() {
                    return s.value(row).to_string();
                }
                panic!("unexpected column type {:?}", a.data_type());
            }
            row -= b.num_rows();
        }
        panic!("row out of range")
    }

    #[test]
    fn both_formats_hold_the_same_columns_and_values() {
        let dir = tempfile::tempdir().unwrap();
        let c = config(dir.path(), &["recording.format=both", "recording.parquet_row_group_rows=16"]).unwrap();
        let summary = run::run(&c, &RunOptions::default()).unwrap();
        let folder = summary.run_folder;
        for table in ["links", "joints", "sensors", "contacts"] {
            let (header, rows) = read_csv(&folder.join(format!("{table}.csv")));
            let (fields, batches, row_groups) = read_parquet(&folder.join(format!("{table}.parquet")));
            let names: Vec<&String> = fields.iter().map(|(n, _)| n).collect();
            assert_eq!(names, header.iter().collect::<Vec<_>>(), "{table}: columns");
            let n_rows: usize = batches.iter().map(RecordBatch::num_rows).sum();
            assert_eq!(n_rows, rows.len(), "{table}: rows");
            assert!(n_rows > 0, "{table}: empty");
            // Row groups of 16 rows were written as the run went.
            assert_eq!(row_groups, n_rows.div_ceil(16), "{table}: row groups");
            for (r, row) in rows.iter().enumerate().step_by(7) {
                for (col, text) in row.iter().enumerate() {
                    assert_eq!(&cell(&batches, col, r), text, "{table} row {r} column {}", header[col]);
                }
            }
            let expected = |name: &str| match (table, name) {
                ("contacts", "step") => DataType::Int64,
                ("contacts", "geom1" | "geom2" | "body1" | "body2") => DataType::Utf8,
                _ => DataType::Float64,
            };
            for (name, data_type) in &fields {
                assert_eq!(data_type, &expected(name), "{table}.{name}");
            }
        }
        let manifest = std::fs::read_to_string(folder.join("manifest.json")).unwrap();
        assert!(manifest.contains("links.parquet") && manifest.contains("links.csv"), "{manifest}");
    }

    #[test]
    fn parquet_only_writes_no_csv() {
        let dir = tempfile::tempdir().unwrap();
        let c = config(dir.path(), &["recording.format=parquet", "recording.contacts=false"]).unwrap();
        let folder = run::run(&c, &RunOptions::default()).unwrap().run_folder;
        for table in ["links", "joints", "sensors"] {
            assert!(folder.join(format!("{table}.parquet")).is_file(), "{table}.parquet");
            assert!(!folder.join(format!("{table}.csv")).exists(), "{table}.csv");
        }
        assert!(!folder.join("contacts.parquet").exists());
        // Default row groups (2500 rows): a 0.5 s run at every 5th step has 101 rows, one group.
        let (_, batches, row_groups) = read_parquet(&folder.join("links.parquet"));
        assert_eq!(row_groups, 1);
        assert_eq!(batches.iter().map(RecordBatch::num_rows).sum::<usize>(), 101);
    }

    #[test]
    fn pandas_and_pyarrow_read_the_tables_when_available() {
        let probe = std::process::Command::new("python3").args(["-c", "import pandas, pyarrow"]).output();
        if !probe.is_ok_and(|o| o.status.success()) {
            eprintln!("skipped: python3 with pandas and pyarrow not available");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let c = config(dir.path(), &["recording.format=both", "recording.parquet_row_group_rows=10"]).unwrap();
        let folder = run::run(&c, &RunOptions::default()).unwrap().run_folder;
        let script = r#"
import sys, pandas as pd, pyarrow.parquet as pq, numpy as np
d = sys.argv[1]
for t in ["links", "joints", "sensors", "contacts"]:
    c = pd.read_csv(f"{d}/{t}.csv")
    p = pd.read_parquet(f"{d}/{t}.parquet")
    assert list(c.columns) == list(p.columns), t
    assert len(c) == len(p), t
    num = c.select_dtypes("number").columns
    assert np.array_equal(c[num].to_numpy(), p[num].to_numpy(), equal_nan=True), t
    assert pq.ParquetFile(f"{d}/{t}.parquet").num_row_groups > 1, t
print("ok")
"#;
        let out = std::process::Command::new("python3").args(["-c", script, &folder.display().to_string()]).output();
        let out = out.unwrap();
        assert!(
            out.status.success(),
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

//! Parquet tables (`recording.format`): same columns and values as the CSV tables, typed
//! columns, row groups written as the run goes, readable by the parquet crate (and by
//! pandas/pyarrow when Python has them).

use crate::common::{default_config_with, output_dir};
use simserpent::config::{Config, ConfigError};
use std::path::Path;

fn config(dir: &Path, overrides: &[&str]) -> Result<Config, ConfigError> {
    let mut all: Vec<String> =
        vec!["general.duration_secs=0.5".into(), "recording.every_n_steps=5".into(), output_dir(&dir.join("runs"))];
    all.extend(overrides.iter().map(|s| s.to_string()));
    default_config_with(&all)
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
    use crate::common::{read_csv, run_folder};
    use arrow_array::{Array, Float64Array, Int64Array, RecordBatch, StringArray};
    use arrow_schema::DataType;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

    type Columns = Vec<(String, DataType)>;

    /// Reads a table's folder of part files in order: (columns, batches, row groups, rows per part).
    fn read_dataset(dir: &Path) -> (Columns, Vec<RecordBatch>, usize, Vec<usize>) {
        assert!(dir.is_dir(), "{} is a folder of parts", dir.display());
        let mut parts: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
        parts.sort();
        let (mut fields, mut batches, mut row_groups, mut part_rows) = (Vec::new(), Vec::new(), 0, Vec::new());
        for (i, part) in parts.iter().enumerate() {
            assert_eq!(part.file_name().unwrap().to_str().unwrap(), format!("part-{i:05}.parquet"));
            let (f, b, g) = read_parquet(part);
            if i > 0 {
                assert_eq!(f, fields, "{}: same columns in every part", part.display());
            }
            fields = f;
            part_rows.push(b.iter().map(RecordBatch::num_rows).sum());
            batches.extend(b);
            row_groups += g;
        }
        (fields, batches, row_groups, part_rows)
    }

    fn read_parquet(path: &Path) -> (Columns, Vec<RecordBatch>, usize) {
        let file = std::fs::File::open(path).unwrap();
        let builder = ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
        let row_groups = builder.metadata().num_row_groups();
        let fields =
            builder.schema().fields().iter().map(|f| (f.name().clone(), f.data_type().clone())).collect::<Vec<_>>();
        let batches = builder.build().unwrap().collect::<Result<Vec<_>, _>>().unwrap();
        (fields, batches, row_groups)
    }

    /// Cell `row` of column `col` as text, in the CSV's spelling.
    fn cell(batches: &[RecordBatch], col: usize, mut row: usize) -> String {
        for b in batches {
            if row < b.num_rows() {
                let a = b.column(col);
                if let Some(f) = a.as_any().downcast_ref::<Float64Array>() {
                    let v = f.value(row);
                    return if v.is_finite() {
                        zmij::Buffer::new().format_finite(v).to_string()
                    } else {
                        v.to_string()
                    };
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
        let folder = run_folder(&c);
        for table in ["links", "joints", "sensors", "contacts"] {
            let (header, rows) = read_csv(&folder.join(format!("{table}.csv")));
            let (fields, batches, row_groups, _) = read_dataset(&folder.join(format!("{table}.parquet")));
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
        let folder = run_folder(&c);
        for table in ["links", "joints", "sensors"] {
            assert!(folder.join(format!("{table}.parquet")).is_dir(), "{table}.parquet");
            assert!(!folder.join(format!("{table}.csv")).exists(), "{table}.csv");
        }
        assert!(!folder.join("contacts.parquet").exists());
        // Default row groups (2500 rows): a 0.5 s run at every 5th step has 101 rows, one group.
        let (_, batches, row_groups, parts) = read_dataset(&folder.join("links.parquet"));
        assert_eq!(row_groups, 1);
        assert_eq!(parts, [101]);
        assert_eq!(batches.iter().map(RecordBatch::num_rows).sum::<usize>(), 101);
    }

    #[test]
    #[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
    fn parts_close_every_rows_per_file_rows_with_any_compression() {
        let dir = tempfile::tempdir().unwrap();
        for compression in ["lz4", "zstd", "snappy", "none"] {
            let c = config(
                dir.path(),
                &[
                    "recording.format=\"parquet\"",
                    "recording.parquet_row_group_rows=8",
                    "recording.parquet_rows_per_file=30",
                    &format!("recording.parquet_compression=\"{compression}\""),
                ],
            )
            .unwrap();
            let folder = run_folder(&c);
            // 101 rows: three full parts and the rest; 30-row parts hold row groups 8+8+8+6.
            let (_, batches, row_groups, parts) = read_dataset(&folder.join("joints.parquet"));
            assert_eq!(parts, [30, 30, 30, 11], "{compression}");
            assert_eq!(row_groups, 4 * 3 + 2, "{compression}");
            let times: Vec<String> = (0..101).map(|r| cell(&batches, 0, r)).collect();
            let parsed: Vec<f64> = times.iter().map(|t| t.parse().unwrap()).collect();
            assert!(parsed.windows(2).all(|w| w[1] > w[0]), "{compression}: rows in order across parts");
        }
    }

    #[test]
    fn a_table_without_rows_still_has_its_columns() {
        let dir = tempfile::tempdir().unwrap();
        // No contact happens in free fall above the floor: the contacts table stays empty.
        let c = config(dir.path(), &["recording.format=\"parquet\"", "snake.head_position_m=[0.0, 0.0, 5.0]"]).unwrap();
        let folder = run_folder(&c);
        let (fields, _, _, parts) = read_dataset(&folder.join("contacts.parquet"));
        assert_eq!(parts, [0]);
        assert!(fields.iter().any(|(n, _)| n == "geom1"), "{fields:?}");
    }

    #[test]
    fn pandas_and_pyarrow_read_the_tables_when_available() {
        let probe = std::process::Command::new("python3").args(["-c", "import pandas, pyarrow"]).output();
        if !probe.is_ok_and(|o| o.status.success()) {
            eprintln!("skipped: python3 with pandas and pyarrow not available");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let c = config(
            dir.path(),
            &["recording.format=both", "recording.parquet_row_group_rows=10", "recording.parquet_rows_per_file=40"],
        )
        .unwrap();
        let folder = run_folder(&c);
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
    assert pq.read_table(f"{d}/{t}.parquet").num_rows == len(c), t
    parts = sorted(__import__("glob").glob(f"{d}/{t}.parquet/part-*.parquet"))
    assert sum(pq.ParquetFile(f).num_row_groups for f in parts) > 1, t
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

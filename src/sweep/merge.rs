//! Shard merging: the summaries of `--shard i/n` invocations joined into `summary.csv`.

use super::summary::SummaryTable;
use super::{SweepError, io_error};
use std::path::{Path, PathBuf};

/// Joins the shard summaries `summary-shard-*-of-N.csv` of `sweep_dir` into `summary.csv` (and
/// `summary.parquet`), ordered by run index. Returns the merged table and the files it read.
/// The columns' types are those of all the merged rows.
///
/// # Errors
/// No shard summaries ([`SweepError::NoShards`]), a file that is not a summary, summaries of
/// different sweeps ([`SweepError::ShardsDiffer`]: other columns), or I/O.
pub fn merge_shards(sweep_dir: &Path) -> Result<(SummaryTable, Vec<PathBuf>), SweepError> {
    let entries = std::fs::read_dir(sweep_dir).map_err(io_error(sweep_dir))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("summary-shard-") && n.ends_with(".csv"))
        })
        .collect();
    files.sort();
    let Some(first) = files.first() else {
        return Err(SweepError::NoShards { folder: sweep_dir.to_path_buf() });
    };
    let mut header: Option<Vec<String>> = None;
    let mut rows: Vec<Vec<String>> = Vec::new();
    for file in &files {
        // Each shard must be a summary on its own; the merged rows are typed together below.
        let table = SummaryTable::read_csv(file)?;
        let (names, cells) = (table.names(), table.rows);
        match &header {
            None => header = Some(names),
            Some(h) if *h != names => {
                return Err(SweepError::ShardsDiffer { path: file.clone(), first: first.clone() });
            }
            Some(_) => {}
        }
        rows.extend(cells.into_iter().map(|r| r.iter().map(|c| c.as_str().to_string()).collect()));
    }
    rows.sort_by_key(|r: &Vec<String>| r.first().and_then(|i| i.parse::<u64>().ok()).unwrap_or(u64::MAX));
    rows.dedup_by(|a, b| a.first() == b.first());
    let merged = SummaryTable::from_text(header.unwrap_or_default(), rows)
        .ok_or_else(|| SweepError::NotASummary { path: first.clone() })?;
    merged.write_csv(&sweep_dir.join("summary.csv"))?;
    #[cfg(feature = "parquet")]
    merged.write_parquet(&sweep_dir.join("summary.parquet"))?;
    Ok((merged, files))
}

//! Shard merging: the summaries of `--shard i/n` invocations joined into `summary.csv`.

use super::summary::SummaryTable;
use super::{SweepError, io_error};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Joins the shard summaries `summary-shard-i-of-n.csv` of `sweep_dir` into `summary.csv` (and
/// `summary.parquet`), ordered by run index. Returns the merged table and the files it read.
/// The columns' types are those of all the merged rows.
///
/// The shards must make up the sweep that `sweep.json` plans: every shard `0 .. n` present, of
/// one split `n`, each run of the plan exactly once, in the shard its index belongs to and with
/// the plan's id. Every file is read by [`crate::files`]' rule (a regular file inside the sweep
/// folder, at most 64 MiB).
///
/// # Errors
/// No shard summaries ([`SweepError::NoShards`]), shards that do not make up the plan
/// ([`SweepError::ShardsIncomplete`]: a missing shard, a run twice or in the wrong shard, a run
/// the plan does not hold), a file that is not a summary, summaries of different sweeps
/// ([`SweepError::ShardsDiffer`]: other columns), a file SimSerpent does not read
/// ([`SweepError::File`]), or I/O.
pub fn merge_shards(sweep_dir: &Path) -> Result<(SummaryTable, Vec<PathBuf>), SweepError> {
    let incomplete = |problem: String| SweepError::ShardsIncomplete { folder: sweep_dir.to_path_buf(), problem };
    let entries = std::fs::read_dir(sweep_dir).map_err(io_error(sweep_dir))?;
    let mut shards: Vec<(usize, usize, PathBuf)> = Vec::new();
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(middle) = name.strip_prefix("summary-shard-").and_then(|n| n.strip_suffix(".csv")) else {
            continue;
        };
        let parsed = middle.split_once("-of-").and_then(|(i, n)| Some((i.parse().ok()?, n.parse().ok()?)));
        match parsed {
            Some((i, n)) if i < n => shards.push((i, n, entry.path())),
            _ => return Err(incomplete(format!("{name} is not named summary-shard-I-of-N.csv with I < N"))),
        }
    }
    shards.sort();
    let Some(&(_, count, ref first)) = shards.first() else {
        return Err(SweepError::NoShards { folder: sweep_dir.to_path_buf() });
    };
    let first = first.clone();
    if let Some((_, other, _)) = shards.iter().find(|(_, n, _)| *n != count) {
        return Err(incomplete(format!("shards of two splits (of {count} and of {other}): merge one sweep's shards")));
    }
    let present: BTreeSet<usize> = shards.iter().map(|(i, _, _)| *i).collect();
    let missing: Vec<String> =
        (0..count).filter(|i| !present.contains(i)).map(|i| format!("summary-shard-{i}-of-{count}.csv")).collect();
    if !missing.is_empty() {
        return Err(incomplete(format!(
            "missing {}: run the sweep with --shard I/{count} for each, then merge again",
            missing.join(", ")
        )));
    }
    let plan = planned_runs(sweep_dir)?;
    let mut header: Option<Vec<String>> = None;
    let mut rows: Vec<Vec<String>> = Vec::new();
    let mut seen: BTreeMap<u64, PathBuf> = BTreeMap::new();
    let files: Vec<PathBuf> = shards.iter().map(|(_, _, p)| p.clone()).collect();
    for (shard, _, file) in &shards {
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
        for row in cells {
            let row: Vec<String> = row.iter().map(|c| c.as_str().to_string()).collect();
            let index = row.first().and_then(|i| i.parse::<u64>().ok()).unwrap_or(u64::MAX);
            let id = row.get(1).map_or("", String::as_str);
            let name = file.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            if index as usize % count != *shard {
                return Err(incomplete(format!(
                    "{name} holds run {index}, which belongs to shard {} of {count}: a shard was copied or renamed",
                    index as usize % count
                )));
            }
            match plan.get(&index) {
                Some(planned) if planned == id => {}
                Some(planned) => {
                    return Err(incomplete(format!(
                        "{name}: run {index} is `{id}`, but sweep.json plans `{planned}`: not this sweep's shard"
                    )));
                }
                None => {
                    return Err(incomplete(format!(
                        "{name}: run {index} is not in sweep.json's plan of {} runs",
                        plan.len()
                    )));
                }
            }
            if let Some(other) = seen.insert(index, file.clone()) {
                return Err(incomplete(format!("run {index} appears twice ({} and {name})", other.display())));
            }
            rows.push(row);
        }
    }
    let absent: Vec<String> = plan.keys().filter(|i| !seen.contains_key(i)).take(10).map(u64::to_string).collect();
    if !absent.is_empty() {
        return Err(incomplete(format!(
            "the shards lack planned runs {} (of {}): run those shards again, then merge",
            absent.join(", "),
            plan.len()
        )));
    }
    rows.sort_by_key(|r: &Vec<String>| r.first().and_then(|i| i.parse::<u64>().ok()).unwrap_or(u64::MAX));
    let merged = SummaryTable::from_text(header.unwrap_or_default(), rows)
        .ok_or_else(|| SweepError::NotASummary { path: first.clone() })?;
    merged.write_csv(&sweep_dir.join("summary.csv"))?;
    #[cfg(feature = "parquet")]
    merged.write_parquet(&sweep_dir.join("summary.parquet"))?;
    Ok((merged, files))
}

/// The plan of `sweep.json`: run index → id.
fn planned_runs(sweep_dir: &Path) -> Result<BTreeMap<u64, String>, SweepError> {
    let path = sweep_dir.join("sweep.json");
    let bad = |problem: String| SweepError::ShardsIncomplete { folder: sweep_dir.to_path_buf(), problem };
    let text = match crate::files::read_text_in(sweep_dir, &path, crate::files::SMALL_FILE_CAP_BYTES) {
        Err(crate::files::FileError::Missing { .. }) => {
            return Err(bad("sweep.json is missing: the plan the shards are checked against".into()));
        }
        other => other?,
    };
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("sweep.json is not the sweep's plan: {e}")))?;
    let runs = value
        .get("runs")
        .and_then(serde_json::Value::as_array)
        .ok_or_else(|| bad("sweep.json has no `runs`".into()))?;
    let mut plan = BTreeMap::new();
    for run in runs {
        let index = run.get("index").and_then(serde_json::Value::as_u64);
        let id = run.get("id").and_then(serde_json::Value::as_str);
        let (Some(index), Some(id)) = (index, id) else {
            return Err(bad("sweep.json: a run without `index` and `id`".into()));
        };
        if plan.insert(index, id.to_string()).is_some() {
            return Err(bad(format!("sweep.json plans run {index} twice")));
        }
    }
    Ok(plan)
}

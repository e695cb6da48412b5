//! Parameter sweeps: plans (grid, random, Latin hypercube), stable run ids and folders, failed
//! runs recorded, restarts that skip finished runs, shards and their merge, the command line.

use crate::common::simserpent;
use simserpent::sweep::{self, RunOutcome, SampleMode, Shard, SummaryTable, SweepError, SweepSpec, Values, Variation};
use std::path::{Path, PathBuf};

/// Short runs on a bare floor.
const BASE: [&str; 3] = ["general.duration_secs=0.2", "recording.every_n_steps=20", "terrain.kind=none"];

/// A grid sweep of `BASE` runs into `dir`, varying `vary`, on 2 threads.
pub(crate) fn spec(dir: &Path, vary: &[&str]) -> SweepSpec {
    SweepSpec {
        config_path: None,
        overrides: BASE.iter().map(|s| s.to_string()).collect(),
        variations: vary.iter().map(|v| Variation::parse(v).unwrap()).collect(),
        mode: SampleMode::Grid,
        samples: 0,
        seed: 1,
        sweep_dir: Some(dir.to_path_buf()),
        threads: 2,
        shard: None,
        progress: false,
    }
}

fn column<'a>(table: &'a SummaryTable, name: &str) -> Vec<&'a str> {
    let i = table.header.iter().position(|h| h == name).unwrap();
    table.rows.iter().map(|r| r[i].as_str()).collect()
}

#[test]
fn grid_plan_is_the_full_product_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let s = spec(dir.path(), &["snake.n_links=5,10,15", "gait.sine_wave.frequency_hz=0.5:2.0:0.5"]);
    let (_, runs) = sweep::plan(&s).unwrap();
    assert_eq!(runs.len(), 12);
    let rendered: Vec<String> = runs.iter().map(|r| format!("{}/{}", r.params[0].1, r.params[1].1)).collect();
    assert_eq!(rendered[..5], ["5/0.5", "5/1.0", "5/1.5", "5/2.0", "10/0.5"]);
    // Ids are derived from the values: the same plan again gives the same ids, all distinct.
    let (_, again) = sweep::plan(&s).unwrap();
    assert_eq!(runs, again);
    let mut ids: Vec<&str> = runs.iter().map(|r| r.id.as_str()).collect();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), 12);
    // The id of a parameter set does not depend on its place in the plan.
    let other = spec(dir.path(), &["snake.n_links=15,5", "gait.sine_wave.frequency_hz=1.5"]);
    let (_, other_runs) = sweep::plan(&other).unwrap();
    let find = |n: i64, f: f64| {
        runs.iter()
            .find(|r| r.params[0].1.as_integer() == Some(n) && r.params[1].1.as_float() == Some(f))
            .unwrap()
            .id
            .clone()
    };
    assert_eq!(other_runs[0].id, find(15, 1.5));
    assert_eq!(other_runs[1].id, find(5, 1.5));
}

#[test]
fn sampling_is_seeded_and_latin_hypercube_uses_every_stratum() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = spec(dir.path(), &["gait.sine_wave.frequency_hz=0.5:2.5", "gait.sine_wave.amplitude_deg=10:50"]);
    s.mode = SampleMode::LatinHypercube;
    s.samples = 8;
    let (_, runs) = sweep::plan(&s).unwrap();
    assert_eq!(runs.len(), 8);
    for (k, (lo, hi)) in [(0.5, 2.5), (10.0, 50.0)].into_iter().enumerate() {
        let mut strata: Vec<usize> = runs
            .iter()
            .map(|r| {
                let x = r.params[k].1.as_float().unwrap();
                assert!((lo..=hi).contains(&x), "{x}");
                ((x - lo) / (hi - lo) * 8.0).floor() as usize
            })
            .collect();
        strata.sort_unstable();
        assert_eq!(strata, (0..8).collect::<Vec<_>>(), "each stratum of key {k} once");
    }
    // Same seed, same samples; another seed, others.
    assert_eq!(sweep::plan(&s).unwrap().1, runs);
    s.seed = 2;
    assert_ne!(sweep::plan(&s).unwrap().1, runs);
    s.mode = SampleMode::Random;
    let (_, random) = sweep::plan(&s).unwrap();
    assert_eq!(random.len(), 8);
    // Integer keys sample integers, whatever the bounds look like.
    let mut s = spec(dir.path(), &["snake.n_links=3.0:6.0"]);
    s.mode = SampleMode::Random;
    s.samples = 20;
    let (_, runs) = sweep::plan(&s).unwrap();
    assert!(runs.iter().all(|r| r.params[0].1.as_integer().is_some_and(|n| (3..=6).contains(&n))));
    assert!(runs.len() <= 4, "equal parameter sets are one run");
}

#[test]
fn bad_arguments_fail_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let e = sweep::plan(&spec(dir.path(), &["snake.n_link=5,6"])).unwrap_err();
    assert!(e.to_string().contains("did you mean `snake.n_links`"), "{e}");
    assert!(matches!(e, SweepError::Config(_)), "bad input (exit code 2): {e}");
    let e = sweep::plan(&spec(dir.path(), &["gait.sine_wave.frequency_hz=0.5:2.0"])).unwrap_err();
    assert!(matches!(e, SweepError::Argument { .. }), "a grid needs a step: {e}");
    assert!(Variation::parse("snake.n_links=").is_err());
    assert!(matches!(Variation::parse("snake.n_links=1:4:1").unwrap().values, Values::Range { .. }));
    assert!(!dir.path().join("runs").exists());
}

#[test]
fn failed_runs_are_recorded_and_redone_finished_runs_skipped() {
    let dir = tempfile::tempdir().unwrap();
    // n_links = 0 is invalid: those runs fail, the others go on.
    let s = spec(dir.path(), &["snake.n_links=0,3", "gait.sine_wave.frequency_hz=0.5,1.0"]);
    let report = sweep::run_sweep(&s).unwrap();
    assert_eq!(report.counts(), (2, 0, 2));
    let table = SummaryTable::read_csv(&dir.path().join("summary.csv")).unwrap();
    assert_eq!(column(&table, "status"), ["failed", "failed", "complete", "complete"]);
    assert!(column(&table, "error")[0].contains("snake.n_links"), "{:?}", column(&table, "error"));
    for metric in [
        "mean_speed_m_per_s",
        "distance_m",
        "actuator_energy_j",
        "peak_contact_force_10ms_n",
        "peak_contact_force_step_n",
    ] {
        let values = column(&table, metric);
        assert!(values[0].is_empty(), "failed run has no {metric}");
        assert!(values[2].parse::<f64>().unwrap() >= 0.0, "{metric}: {}", values[2]);
    }
    assert!(column(&table, "actuator_energy_j")[2].parse::<f64>().unwrap() > 0.0);
    assert!(column(&table, "forward_speed_m_per_s")[2].parse::<f64>().unwrap().is_finite());
    for (row, folder) in report.rows.iter().zip(column(&table, "run_folder")) {
        assert_eq!(folder, format!("runs/{}", row.run.id));
        let complete = matches!(row.outcome, RunOutcome::Complete(_));
        assert_eq!(dir.path().join(folder).join("manifest.json").is_file(), complete);
    }
    // An interrupted run (manifest still "incomplete") is redone too.
    let interrupted = dir.path().join(column(&table, "run_folder")[3]).join("manifest.json");
    let text = std::fs::read_to_string(&interrupted).unwrap().replace("\"complete\"", "\"incomplete\"");
    std::fs::write(&interrupted, text).unwrap();
    let again = sweep::run_sweep(&s).unwrap();
    assert_eq!(again.counts(), (1, 1, 2), "one skipped, one redone, two failed again");
    let table2 = SummaryTable::read_csv(&dir.path().join("summary.csv")).unwrap();
    assert_eq!(column(&table2, "run_id"), column(&table, "run_id"));
    assert_eq!(column(&table2, "mean_speed_m_per_s"), column(&table, "mean_speed_m_per_s"));
    #[cfg(feature = "parquet")]
    assert!(dir.path().join("summary.parquet").is_file());
}

fn files_of(folder: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = ["links.csv", "joints.csv", "sensors.csv", "contacts.csv", "model.xml"]
        .iter()
        .map(|f| (f.to_string(), std::fs::read(folder.join(f)).unwrap()))
        .collect();
    v.sort();
    v
}

#[test]
fn shards_merge_into_the_full_summary_and_runs_are_deterministic() {
    let full_dir = tempfile::tempdir().unwrap();
    let vary = ["snake.n_links=3,4,5", "general.seed=1,2"];
    let full = sweep::run_sweep(&spec(full_dir.path(), &vary)).unwrap();
    assert_eq!(full.counts(), (6, 0, 0));
    let shard_dir = tempfile::tempdir().unwrap();
    for i in 0..4 {
        let mut s = spec(shard_dir.path(), &vary);
        s.shard = Some(Shard { index: i, count: 4 });
        s.threads = 1;
        let report = sweep::run_sweep(&s).unwrap();
        assert!(report.rows.iter().all(|r| r.run.index % 4 == i));
        assert!(shard_dir.path().join(format!("summary-shard-{i}-of-4.csv")).is_file());
    }
    let (merged, files) = sweep::merge_shards(shard_dir.path()).unwrap();
    assert_eq!(files.len(), 4);
    let whole = SummaryTable::read_csv(&full_dir.path().join("summary.csv")).unwrap();
    assert_eq!(merged.header, whole.header);
    for name in ["run_index", "run_id", "snake.n_links", "general.seed", "status", "distance_m", "actuator_energy_j"] {
        assert_eq!(column(&merged, name), column(&whole, name), "{name}");
    }
    assert_eq!(SummaryTable::read_csv(&shard_dir.path().join("summary.csv")).unwrap(), merged);
    // Same parameters, same folder name and the same recorded data, in either sweep.
    for row in &full.rows {
        let a = full_dir.path().join("runs").join(&row.run.id);
        let b = shard_dir.path().join("runs").join(&row.run.id);
        assert_eq!(files_of(&a), files_of(&b), "{}", row.run.id);
    }
}

#[test]
fn command_line_sweep_and_merge() {
    let dir = tempfile::tempdir().unwrap();
    let mut args: Vec<String> = ["sweep", "--vary", "snake.n_links=3,4", "--vary", "general.seed=1:2:1", "--quiet"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    for b in BASE {
        args.extend(["--set".to_string(), b.to_string()]);
    }
    let as_str = |extra: &[&str]| -> Vec<String> {
        let mut a = args.clone();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let run = |a: Vec<String>| {
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        simserpent(dir.path(), &refs)
    };
    let out = run(as_str(&["--shard", "0/2", "--threads", "1"]));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = run(as_str(&["--shard", "1/2"]));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let sweep_dir: PathBuf = dir.path().join("runs").join("sweep-default");
    let out = simserpent(dir.path(), &["sweep-merge", sweep_dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let merged = SummaryTable::read_csv(&sweep_dir.join("summary.csv")).unwrap();
    assert_eq!(column(&merged, "run_index"), ["0", "1", "2", "3"]);
    // A second full run finds everything done.
    let out = run(as_str(&[]));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && stdout.contains("4 already complete"), "{stdout}");
    // Bad input: exit code 2.
    let out = simserpent(dir.path(), &["sweep", "--vary", "snake.n_lnks=3,4"]);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    let out = simserpent(dir.path(), &["sweep", "--vary", "snake.n_links=3", "--shard", "2/2"]);
    assert_eq!(out.status.code(), Some(2));
    // A failing run: exit code 1, the summary says which.
    let out = simserpent(dir.path(), &["sweep", "--vary", "snake.n_links=0", "--set", "general.duration_secs=0.1"]);
    assert_eq!(out.status.code(), Some(1));
}

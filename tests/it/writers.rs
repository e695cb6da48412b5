//! The writer threads (`record::offload`): the files of a run written on writer threads are byte
//! for byte those of the synchronous path (everything formatted and written on the step-loop
//! thread), and a write error on a writer thread still fails the run naming the file.

use crate::common::{
    assert_a_full_disk_fails_the_run_naming, default_config_with, manifest, signal_and_wait, simserpent, spawn_run,
    text, wait_for_rows,
};
use simserpent::run::{self, RunOptions};
use std::collections::BTreeMap;
use std::path::Path;

/// Every file under `folder` (recursively: a Parquet table is a folder of parts) with its bytes,
/// by path relative to `folder`.
fn files(folder: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let name = path.strip_prefix(root).unwrap().display().to_string();
                out.insert(name, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(folder, folder, &mut out);
    out
}

/// A short job recording every step in every format (CSV, Parquet with several row groups and
/// parts, the ROS 2 bag), with the `estimates` table and `state.csv`, over a number of rows that
/// is not a multiple of the hand-over batch: run with writer threads and with the writers
/// inline, every file but the manifest (wall time) is the same, byte for byte.
#[test]
#[cfg_attr(not(feature = "parquet"), ignore = "records Parquet, which needs the `parquet` feature")]
fn files_written_on_writer_threads_are_those_of_the_synchronous_path() {
    let dir = tempfile::tempdir().unwrap();
    let config = default_config_with(&[
        "general.duration_secs=0.6".into(),
        "recording.every_n_steps=1".into(),
        r#"recording.format=["csv","parquet","mcap"]"#.into(),
        "recording.parquet_row_group_rows=64".into(),
        "recording.parquet_rows_per_file=256".into(),
        "estimation.enabled=true".into(),
    ])
    .unwrap();
    let mut written = Vec::new();
    for inline_writers in [false, true] {
        let folder = dir.path().join(if inline_writers { "inline" } else { "threaded" });
        let options = RunOptions { run_folder: Some(folder.clone()), inline_writers, ..RunOptions::default() };
        run::run(&config, &options).unwrap();
        let m = manifest(&folder);
        assert_eq!(m["status"], "complete");
        // 601 instants (0.6 s at 1 ms, both ends) = 37 batches of 16 and 9 rows.
        assert_eq!(m["tables"][0], serde_json::json!(["links.csv", 601]), "{m}");
        let mut f = files(&folder);
        f.remove("manifest.json");
        written.push(f);
    }
    let (threaded, inline) = (&written[0], &written[1]);
    for name in ["links.csv", "contacts.csv", "estimates.csv", "state.csv", "run.mcap", "config.toml"] {
        assert!(threaded.contains_key(name), "{name} missing: {:?}", threaded.keys().collect::<Vec<_>>());
    }
    let parts = threaded.keys().filter(|k| k.starts_with("links.parquet/")).count();
    assert_eq!(parts, 3, "601 rows in parts of 256: {:?}", threaded.keys().collect::<Vec<_>>());
    assert_eq!(threaded.keys().collect::<Vec<_>>(), inline.keys().collect::<Vec<_>>());
    for (name, bytes) in threaded {
        assert!(bytes == &inline[name], "{name} differs ({} against {} bytes)", bytes.len(), inline[name].len());
    }
}

/// A file-size limit (`ulimit -f`, SIGXFSZ ignored: writes fail with EFBIG) hits the ROS 2 bag,
/// which is written on a writer thread: the run fails with exit 1 naming `run.mcap`, and the
/// manifest says so.
#[test]
fn a_write_error_of_the_bag_on_its_writer_thread_fails_the_run_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let args = "--set general.duration_secs=5 --set recording.every_n_steps=1 \
                --set 'recording.format=\"mcap\"' --set render.record_state=false";
    assert_a_full_disk_fails_the_run_naming(dir.path(), args, "run.mcap");
}

/// SIGTERM during an every-step run writing CSV, the ROS 2 bag and `state.csv` on their writer
/// threads: the run stops with exit 130 and an `incomplete` manifest, and every file holds the
/// same recorded instants, whole: the CSV tables and `state.csv` end with a whole row, the bag
/// is finished (summary and footer: the `mcap` reader reads every message).
#[test]
fn an_interrupted_run_leaves_every_writer_thread_file_whole_and_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let sets = ["general.duration_secs=3600", "recording.every_n_steps=1", r#"recording.format=["csv","mcap"]"#];
    let mut guard = spawn_run(dir.path(), &sets);
    let run = wait_for_rows(&mut guard, dir.path(), 200);
    let out = signal_and_wait(guard, "TERM");
    assert_eq!(out.status.code(), Some(130), "{}", text(&out));
    let m = manifest(&run);
    assert_eq!(m["status"], "incomplete", "{m}");
    let count =
        |file: &str| m["tables"].as_array().unwrap().iter().find(|t| t[0] == file).and_then(|t| t[1].as_u64()).unwrap();
    let instants = count("links.csv");
    assert!(instants >= 199, "{m}");
    for file in ["links.csv", "joints.csv", "sensors.csv", "state.csv"] {
        let (_, rows) = crate::common::read_complete_csv(&run.join(file));
        assert_eq!(rows.len() as u64, instants, "{file}");
    }
    assert_eq!(count("run.mcap"), instants, "{m}");
    let bag = std::fs::read(run.join("run.mcap")).unwrap();
    let clocks = mcap::MessageStream::new(&bag)
        .unwrap()
        .map(|message| message.unwrap())
        .filter(|message| message.channel.topic == "/clock")
        .count();
    assert_eq!(clocks as u64, instants, "one /clock message per recorded instant");
    // Finished: the summary section is there (a bag cut off by a kill has none).
    assert!(mcap::Summary::read(&bag).unwrap().is_some(), "run.mcap has its summary");
}

/// `simserpent bench --json` reports the CPU time per step of the step-loop thread and of the
/// writer threads: a CSV run's writer threads work (formatting every row), the same run with
/// the rows discarded leaves them almost idle while the loop does the same work, and the bare
/// engine has no writer threads.
#[test]
fn bench_reports_cpu_time_per_step_of_the_loop_and_of_the_writer_threads() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = simserpent(
        dir.path(),
        &[
            "bench",
            "--links",
            "5",
            "--duration-secs",
            "0.5",
            "--set",
            "recording.every_n_steps=1",
            "--discard-rows",
            "--json",
            "--output-dir",
            "bench",
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let rows = doc["rows"].as_array().expect("rows");
    let row = |mode: &str| rows.iter().find(|r| r["mode"] == mode).unwrap_or_else(|| panic!("no row {mode}"));
    let num = |r: &serde_json::Value, key: &str| r[key].as_f64().unwrap_or_else(|| panic!("{key}: {r}"));
    let (bare, csv, discarded) =
        (row("bare, gait + ground"), row("full pipeline (CSV)"), row("full pipeline (CSV, rows discarded)"));
    for r in [bare, csv, discarded] {
        // A thread's CPU time per step is positive and, on a thread
        // that never waits for a core, at most its wall time per step (plus clock granularity).
        let (cpu, wall) = (num(r, "loop_cpu_us_per_step"), num(r, "wall_us_per_step"));
        assert!(cpu > 0.0 && cpu <= wall * 1.05 + 1.0, "{}: loop CPU {cpu} µs, wall {wall} µs", r["mode"]);
    }
    assert_eq!(num(bare, "writer_cpu_us_per_step"), 0.0);
    assert_eq!(bare["writer_threads"], 0);
    // Tables and state.csv: two writer threads.
    assert_eq!(csv["writer_threads"], 2, "{csv}");
    let (formatting, idle) = (num(csv, "writer_cpu_us_per_step"), num(discarded, "writer_cpu_us_per_step"));
    assert!(idle < 0.5 * formatting, "writers' CPU per step: {formatting} µs writing, {idle} µs discarding");
    let ratio = num(csv, "cpu_ratio_to_bare_gait_ground");
    let expected = num(bare, "loop_cpu_us_per_step") / num(csv, "loop_cpu_us_per_step");
    assert!((ratio - expected).abs() < 1e-9, "{ratio} against {expected}");
    assert!(num(csv, "writer_longest_batch_ms") > 0.0 && num(csv, "loop_lead_ms") > 0.0, "{csv}");
    // The share of the recording's CPU work on the loop thread, from the same figures.
    let none = row("full pipeline (no tables)");
    let delta = (num(csv, "loop_cpu_us_per_step") - num(none, "loop_cpu_us_per_step")).max(0.0);
    let share = num(csv, "loop_share_of_recording");
    assert!((share - delta / (delta + formatting)).abs() < 1e-9, "{share} against {delta} and {formatting}");
    assert!(bare["loop_share_of_recording"].is_null(), "{bare}");
}

/// `--min-cpu-ratio` fails the bench (exit 1, naming the ratio) when the step loop's CPU time
/// ratio is below the floor, and rejects a floor that is not a positive number (exit 2).
#[test]
fn the_cpu_ratio_guard_fails_below_its_floor_and_rejects_a_bad_floor() {
    let dir = tempfile::tempdir().expect("temp dir");
    let bench = |floor: &str| {
        simserpent(
            dir.path(),
            &["bench", "--links", "3", "--duration-secs", "0.05", "--min-cpu-ratio", floor, "--output-dir", "bench"],
        )
    };
    // No pipeline needs 1000 times less CPU per step than the bare engine.
    let out = bench("1000");
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(
        text(&out).contains("step-loop CPU time per step") && text(&out).contains("below the floor 1000"),
        "{}",
        text(&out)
    );
    let out = bench("0");
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("--min-cpu-ratio 0: must be a number greater than 0"), "{}", text(&out));
}

/// `--max-loop-share` takes a share strictly between 0 and 1 (exit 2 naming the value
/// otherwise); the share itself is checked on constructed rows in `bench`'s unit tests.
#[test]
fn the_loop_share_guard_rejects_a_share_outside_0_to_1() {
    let dir = tempfile::tempdir().expect("temp dir");
    for bad in ["0", "1", "1.5", "NaN"] {
        let out = simserpent(
            dir.path(),
            &["bench", "--links", "3", "--duration-secs", "0.05", "--max-loop-share", bad, "--output-dir", "bench"],
        );
        assert_eq!(out.status.code(), Some(2), "{bad}: {}", text(&out));
        assert!(
            text(&out).contains(&format!("--max-loop-share {bad}: must be a number between 0 and 1")),
            "{}",
            text(&out)
        );
    }
}

//! Dying processes and hostile surroundings: closed pipes, a full
//! disk at every stage of a run, SIGKILL mid-run (CSV and Parquet), signals during set-up and
//! plotting, and sweeps resumed from their manifests.

use simserpent::sweep::{self, SampleMode, SweepSpec, Variation};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The binary under test: `SIMSERPENT_TEST_EXE` if set (a copy, where several worktrees share one
/// target folder), else the one cargo built.
fn exe() -> PathBuf {
    std::env::var_os("SIMSERPENT_TEST_EXE")
        .map_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_simserpent")), PathBuf::from)
}

use crate::common::{KillOnDrop, spawn_run, text};

/// Run folders under `dir`, sorted.
fn run_folders(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries.map(|e| e.unwrap().path()).filter(|p| p.is_dir()).collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

fn manifest(run: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(run.join("manifest.json")).unwrap();
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: invalid JSON ({e}):\n{text}", run.display()))
}

// --- 13. a resumed sweep --------------------------------------------------------------------

/// A sweep rerun that skips its finished runs reads their metrics back from the manifests: its
/// summary.csv must be the fresh sweep's, byte for byte but the wall time of this invocation.
#[test]
fn a_resumed_sweep_writes_the_same_summary_as_a_fresh_one() {
    let dir = tempfile::tempdir().unwrap();
    let spec = SweepSpec {
        config_path: None,
        overrides: ["general.duration_secs=0.3", "recording.every_n_steps=20", "terrain.kind=\"none\""]
            .iter()
            .map(|s| s.to_string())
            .collect(),
        variations: ["snake.n_links=3,4", "gait.sine_wave.frequency_hz=0.7,1.3"]
            .iter()
            .map(|v| Variation::parse(v).unwrap())
            .collect(),
        mode: SampleMode::Grid,
        samples: 0,
        seed: 1,
        sweep_dir: Some(dir.path().to_path_buf()),
        threads: 2,
        shard: None,
        progress: false,
    };
    let fresh = sweep::run_sweep(&spec).unwrap();
    assert_eq!(fresh.counts(), (4, 0, 0));
    let fresh_csv = std::fs::read_to_string(dir.path().join("summary.csv")).unwrap();
    let resumed = sweep::run_sweep(&spec).unwrap();
    assert_eq!(resumed.counts(), (0, 4, 0), "every run is read back from its manifest");
    let resumed_csv = std::fs::read_to_string(dir.path().join("summary.csv")).unwrap();
    // Everything but the `wall_secs` column (this invocation's time for a fresh run, the
    // manifest's for a skipped one).
    let without_wall = |csv: &str| -> Vec<String> {
        let wall = csv.lines().next().unwrap().split(',').position(|h| h == "wall_secs").unwrap();
        csv.lines()
            .map(|l| {
                let mut cells: Vec<&str> = l.split(',').collect();
                cells.remove(wall);
                cells.join(",")
            })
            .collect()
    };
    let (a, b) = (without_wall(&fresh_csv), without_wall(&resumed_csv));
    assert_eq!(a.len(), 5);
    for (fresh_line, resumed_line) in a.iter().zip(&b) {
        assert_eq!(fresh_line, resumed_line);
    }
    assert_eq!(a, b);
}

// --- 7. closed pipes ------------------------------------------------------------------------

/// Runs `simserpent ARGS` in `dir` with its standard output (or error) a pipe whose reader is
/// gone before the first byte is written, as in `simserpent check | true`.
fn with_closed_pipe(dir: &Path, args: &[&str], close_stderr: bool) -> Output {
    let mut command = Command::new(exe());
    command.current_dir(dir).args(args).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    let mut child = command.spawn().unwrap();
    if close_stderr {
        drop(child.stderr.take());
    } else {
        drop(child.stdout.take());
    }
    child.wait_with_output().unwrap()
}

const QUICK_RUN: [&str; 6] =
    ["--set", "general.duration_secs=0.2", "--set", "recording.every_n_steps=10", "--set", "terrain.kind=\"none\""];

/// Every command that prints exits with its own exit code, without a panic, when its reader
/// has gone (`simserpent check | head -1`); a run still closes its tables and manifest.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_closed_pipe_ends_printing_quietly_with_the_commands_own_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let quick = |cmd: &[&str]| -> Vec<String> { cmd.iter().chain(QUICK_RUN.iter()).map(|s| s.to_string()).collect() };
    let cases: Vec<(Vec<String>, i32)> = vec![
        (vec!["check".into()], 0),
        (vec!["model".into()], 0),
        (vec!["--help".into()], 0),
        (vec!["--version".into()], 0),
        (vec!["init".into(), "fresh.toml".into()], 0),
        (quick(&["run", "--quiet", "--set", "general.run_name=\"piped\""]), 0),
        (quick(&["sweep", "--quiet", "--vary", "snake.n_links=3,4", "--sweep-dir", "sw", "--shard", "0/2"]), 0),
        (quick(&["sweep", "--quiet", "--vary", "snake.n_links=3,4", "--sweep-dir", "sw", "--shard", "1/2"]), 0),
        (vec!["sweep-merge".into(), "sw".into()], 0),
        (quick(&["bench", "--links", "3", "--duration-secs", "0.05", "--output-dir", "bench"]), 0),
        (vec!["check".into(), "--set".into(), "general.no_such_key=1".into()], 2),
    ];
    let mut problems = Vec::new();
    let mut handled = 0;
    for (args, code) in &cases {
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = with_closed_pipe(d, &refs, false);
        let stderr = String::from_utf8_lossy(&out.stderr);
        if out.status.code() != Some(*code) || stderr.contains("panicked") || stderr.contains("Broken pipe") {
            problems.push(format!("{args:?}: {:?}\n{stderr}", out.status));
        } else {
            handled += 1;
        }
    }
    // The piped run finished its folder: manifest complete, tables listed with their rows.
    let run = run_folders(&d.join("runs")).into_iter().find(|p| p.to_string_lossy().contains("piped")).unwrap();
    let m = manifest(&run);
    assert_eq!(m["status"], "complete", "{m}");
    assert_eq!(m["tables"].as_array().unwrap().len(), 4, "{m}");
    // `plot` prints too (on the piped run's folder).
    let out = with_closed_pipe(d, &["plot", run.to_str().unwrap()], false);
    if out.status.code() == Some(0) && !String::from_utf8_lossy(&out.stderr).contains("panicked") {
        handled += 1;
    } else {
        problems.push(format!("plot: {:?} {}", out.status, text(&out)));
    }
    // A closed standard error: the error's exit code, not a panic's 101.
    for (args, code) in [(vec!["check", "--set", "general.no_such_key=1"], 2), (vec!["plot", "no-such-folder"], 2)] {
        let out = with_closed_pipe(d, &args, true);
        if out.status.code() == Some(code) {
            handled += 1;
        } else {
            problems.push(format!("{args:?} with stderr closed: {:?}", out.status));
        }
    }
    eprintln!("closed pipes: {handled} of {} commands handled cleanly", cases.len() + 3);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// --- shared checks of a run folder ----------------------------------------------------------

/// The table files present in a run folder (`*.csv` but `state.csv`, `*.parquet` folders).
fn table_files(run: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(run)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| (n.ends_with(".csv") && n != "state.csv") || n.ends_with(".parquet"))
        .collect();
    names.sort();
    names
}

/// Whole rows of a CSV table: checks that every line but possibly a cut last one (`cut_ok`:
/// after SIGKILL) has the header's number of fields. Returns the number of whole rows.
fn csv_whole_rows(path: &Path, cut_ok: bool) -> Result<u64, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let text = String::from_utf8_lossy(&bytes);
    let complete = match text.rfind('\n') {
        Some(i) => &text[..=i],
        None => return Err(format!("{}: no header line", path.display())),
    };
    if complete.len() != text.len() && !cut_ok {
        return Err(format!("{}: ends in a partial row", path.display()));
    }
    let mut lines = complete.lines();
    let width = lines.next().unwrap().split(',').count();
    let mut rows = 0;
    for (i, line) in lines.enumerate() {
        let fields = line.split(',').count();
        if fields != width {
            return Err(format!("{}: row {i} has {fields} of {width} fields", path.display()));
        }
        rows += 1;
    }
    Ok(rows)
}

/// The rows of a Parquet table folder as the parquet crate reads its visible parts (names not
/// starting with `.` or `_`, as pyarrow's discovery does).
#[cfg(feature = "parquet")]
fn parquet_rows(dir: &Path) -> Result<u64, String> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let mut rows = 0;
    let mut parts = 0;
    for entry in std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))? {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with('.') || name.starts_with('_') {
            continue;
        }
        let file = std::fs::File::open(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let reader = SerializedFileReader::new(file).map_err(|e| format!("{}: {e}", path.display()))?;
        rows += reader.metadata().file_metadata().num_rows() as u64;
        // Read every row too, not just the footer.
        let read = reader.get_row_iter(None).map_err(|e| format!("{}: {e}", path.display()))?.count() as u64;
        if read != reader.metadata().file_metadata().num_rows() as u64 {
            return Err(format!("{}: footer and rows disagree", path.display()));
        }
        parts += 1;
    }
    // A table that failed before its first part closed is an empty folder (0 rows).
    let _ = parts;
    Ok(rows)
}

#[cfg(not(feature = "parquet"))]
fn parquet_rows(dir: &Path) -> Result<u64, String> {
    Err(format!("{}: built without the parquet feature", dir.display()))
}

/// A Python with pandas and pyarrow: `SIMSERPENT_TEST_PYTHON`, else the repository's `.venv`,
/// else `python3`; `None` when none has them.
fn python_with_pandas() -> Option<PathBuf> {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python3");
    let candidates =
        [std::env::var_os("SIMSERPENT_TEST_PYTHON").map(PathBuf::from), Some(venv), Some("python3".into())];
    candidates
        .into_iter()
        .flatten()
        .find(|p| Command::new(p).args(["-c", "import pandas, pyarrow"]).output().is_ok_and(|o| o.status.success()))
}

/// Checks what a run folder promises whatever ended the run: a valid manifest whose status
/// is `expected` (one of), no temporary manifest, the reserve file gone (unless killed), every
/// table present listed with exactly the rows it holds. Returns the manifest.
fn check_run_folder(run: &Path, expected: &[&str], killed: bool) -> Result<serde_json::Value, String> {
    let text = std::fs::read_to_string(run.join("manifest.json")).map_err(|e| format!("{}: {e}", run.display()))?;
    let m: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("invalid manifest ({e}): {text}"))?;
    let status = m["status"].as_str().unwrap_or("?");
    if !expected.contains(&status) {
        return Err(format!("status {status}, expected {expected:?}: {m}"));
    }
    if run.join(".manifest.json.tmp").exists() {
        return Err("temporary manifest left".into());
    }
    if !killed && run.join(".simserpent-reserve").exists() {
        return Err("reserve file left".into());
    }
    let listed: Vec<(String, u64)> = m["tables"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| (t[0].as_str().unwrap().to_string(), t[1].as_u64().unwrap()))
        .collect();
    let present = table_files(run);
    if !killed {
        let mut names: Vec<String> = listed.iter().map(|(n, _)| n.clone()).collect();
        names.sort();
        if names != present {
            return Err(format!("tables present {present:?}, listed {names:?}"));
        }
    }
    for name in &present {
        let path = run.join(name);
        let rows = if name.ends_with(".csv") { csv_whole_rows(&path, killed)? } else { parquet_rows(&path)? };
        if let Some((_, n)) = listed.iter().find(|(l, _)| l == name)
            && *n != rows
        {
            return Err(format!("{name}: {rows} whole rows, the manifest says {n}"));
        }
    }
    Ok(m)
}

// --- 8. a full disk -------------------------------------------------------------------------

/// Unmounts a test's tmpfs when the test ends (also when it fails).
struct Unmount(PathBuf);

impl Drop for Unmount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

fn mount_tmpfs(at: &Path, size: &str) -> Option<Unmount> {
    std::fs::create_dir_all(at).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs", at.to_str().unwrap()])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    mounted.then(|| Unmount(at.to_path_buf()))
}

/// Runs on disks of 4 KiB to 3 MiB (tmpfs; skipped where this process may not mount one): the
/// disk fills during set-up, during the run or at its end. Whatever the stage, the run exits 1
/// naming "No space left", and either leaves no run folder or one whose manifest is valid
/// JSON, says `failed` and why, and lists every table file with exactly the whole rows it
/// holds (no partial last row); or the run fits and is `complete`.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_full_disk_at_any_stage_leaves_a_valid_manifest_listing_whole_rows() {
    let dir = tempfile::tempdir().unwrap();
    if mount_tmpfs(&dir.path().join("probe"), "4k").is_none() {
        eprintln!("skipped: cannot mount a tmpfs here (needs root)");
        return;
    }
    // Coarse steps through set-up and the run, then 8 KiB steps where the run's last buffers,
    // footers and manifest meet the end of the disk.
    let mut sizes_kib =
        vec![4, 8, 12, 16, 24, 32, 40, 48, 56, 64, 80, 96, 128, 192, 256, 384, 512, 768, 1024, 1536, 2048];
    sizes_kib.extend((2056..=2400).step_by(8));
    sizes_kib.extend([3072, 4096, 5120]);
    let mut stages = std::collections::BTreeMap::<&str, (u32, u32)>::new();
    let mut problems = Vec::new();
    for (i, size) in sizes_kib.iter().enumerate() {
        for format in ["csv", "both"] {
            if format == "both" && (i % 2 == 1 || (2056..=2400).contains(size)) {
                continue;
            }
            let disk = dir.path().join(format!("disk-{size}-{format}"));
            let Some(_unmount) = mount_tmpfs(&disk, &format!("{size}k")) else {
                problems.push(format!("{size} KiB: cannot mount"));
                continue;
            };
            let out = Command::new(exe())
                .current_dir(&disk)
                .args(["run", "--quiet", "--set", "general.duration_secs=0.1", "--set", "recording.every_n_steps=1"])
                .args([
                    "--set",
                    &format!("recording.format=\"{format}\""),
                    "--set",
                    "recording.parquet_rows_per_file=40",
                ])
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr).to_string();
            let runs = run_folders(&disk.join("runs"));
            let case = format!("{size} KiB, {format}");
            let (stage, verdict) = match (out.status.code(), runs.as_slice()) {
                (Some(1), []) => (
                    "set-up, before the run folder",
                    if stderr.contains("No space left") { Ok(()) } else { Err(stderr) },
                ),
                (Some(code @ (0 | 1)), [run]) => {
                    let expected: &[&str] = if code == 0 { &["complete"] } else { &["failed"] };
                    match check_run_folder(run, expected, false) {
                        Ok(_) if code == 0 => ("fits", Ok(())),
                        Ok(m) => {
                            let error = m["error"].as_str().unwrap_or("");
                            let stage = if m["steps"].as_u64() == Some(0) && m["tables"].as_array().unwrap().is_empty()
                            {
                                "set-up, in the run folder"
                            } else if m["simulated_secs"].as_f64() >= m["duration_secs"].as_f64().map(|d| d * 0.999) {
                                "at the end"
                            } else {
                                "during the run"
                            };
                            if error.contains("No space left") && stderr.contains("No space left") {
                                (stage, Ok(()))
                            } else {
                                (stage, Err(format!("error {error:?}, stderr {stderr}")))
                            }
                        }
                        Err(e) => ("unknown", Err(e)),
                    }
                }
                _ => ("unknown", Err(format!("exit {:?}, {} run folders: {stderr}", out.status, runs.len()))),
            };
            let entry = stages.entry(stage).or_default();
            entry.0 += 1;
            match verdict {
                Ok(()) => entry.1 += 1,
                Err(e) => problems.push(format!("{case} ({stage}): {e}")),
            }
        }
    }
    for (stage, (cases, clean)) in &stages {
        eprintln!("full disk, {stage}: {cases} cases, {clean} handled cleanly");
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    for stage in ["set-up, before the run folder", "set-up, in the run folder", "during the run", "at the end", "fits"]
    {
        assert!(stages.contains_key(stage), "no case filled the disk {stage}: {stages:?}");
    }
}

// --- 9. SIGKILL mid-run ---------------------------------------------------------------------

/// Waits (up to two minutes) until `ready` says so or the child ends; false if it ended.
fn wait_until(child: &mut Child, mut ready: impl FnMut() -> bool) -> bool {
    let started = Instant::now();
    while !ready() {
        assert!(started.elapsed() < Duration::from_secs(120), "not ready after 120 s");
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    true
}

/// Visible part files of a Parquet table folder.
fn visible_parts(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |entries| {
        entries.filter(|e| e.as_ref().is_ok_and(|e| !e.file_name().to_string_lossy().starts_with('.'))).count()
    })
}

/// A run killed with SIGKILL (as the OOM killer does) in the middle, in every recording format
/// and at several moments: the manifest is valid JSON and says `incomplete`; every CSV line but
/// a cut last one is a whole row; every Parquet table reads back, with the parquet crate and —
/// when a Python with pandas and pyarrow is there — with `pd.read_parquet("<run>/<table>.parquet")`.
#[test]
fn a_killed_run_leaves_every_table_readable_in_every_format() {
    let python = python_with_pandas();
    if python.is_none() {
        eprintln!("pandas check skipped: no python3 with pandas and pyarrow (set SIMSERPENT_TEST_PYTHON)");
    }
    let (mut cases, mut clean) = (0, 0);
    let mut problems = Vec::new();
    // Parquet tables need the `parquet` feature; without it CSV only.
    let formats: &[&str] = if cfg!(feature = "parquet") { &["csv", "parquet", "both"] } else { &["csv"] };
    for &format in formats {
        for extra_ms in [0, 150, 500] {
            cases += 1;
            let dir = tempfile::tempdir().unwrap();
            let mut guard = KillOnDrop(Some(
                Command::new(exe())
                    .current_dir(dir.path())
                    .args([
                        "run",
                        "--quiet",
                        "--set",
                        "general.duration_secs=3600",
                        "--set",
                        "recording.every_n_steps=1",
                    ])
                    .args([
                        "--set",
                        &format!("recording.format=\"{format}\""),
                        "--set",
                        "recording.parquet_rows_per_file=50",
                    ])
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .unwrap(),
            ));
            let child = guard.0.as_mut().unwrap();
            let runs = dir.path().join("runs");
            let started = wait_until(child, || {
                run_folders(&runs).first().is_some_and(|run| match format {
                    "csv" => std::fs::metadata(run.join("links.csv")).is_ok_and(|m| m.len() > 200_000),
                    _ => visible_parts(&run.join("links.parquet")) >= 1,
                })
            });
            assert!(started, "{format}: the run ended by itself");
            std::thread::sleep(Duration::from_millis(extra_ms));
            child.kill().unwrap();
            child.wait().unwrap();
            guard.0 = None;
            let run = &run_folders(&runs)[0];
            let case = format!("{format}, killed {extra_ms} ms after the first rows");
            let mut ok = match check_run_folder(run, &["incomplete"], true) {
                Ok(_) => true,
                Err(e) => {
                    problems.push(format!("{case}: {e}"));
                    false
                }
            };
            if let (Some(python), true) = (&python, format != "csv") {
                // A table whose first part had not closed yet is an empty folder: an empty frame.
                let script = "import sys, pandas as pd\nfor t in sys.argv[1:]:\n    print(t, pd.read_parquet(t).shape)";
                let tables: Vec<String> = ["links", "joints", "sensors", "contacts"]
                    .iter()
                    .map(|t| run.join(format!("{t}.parquet")).display().to_string())
                    .collect();
                let out = Command::new(python).arg("-c").arg(script).args(&tables).output().unwrap();
                if !out.status.success() {
                    problems.push(format!("{case}: pandas: {}", text(&out)));
                    ok = false;
                }
            }
            if ok {
                clean += 1;
            }
        }
    }
    eprintln!("SIGKILL mid-run: {cases} cases, {clean} handled cleanly");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// --- 10. signals during set-up, the run and plotting ----------------------------------------

fn send(child: &Child, signal: &str) {
    let status = Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap();
    assert!(status.success());
}

/// Waits for the child's end (at most `limit`) and returns its output.
fn finish(mut guard: KillOnDrop, limit: Duration) -> Output {
    let child = guard.0.as_mut().unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        assert!(started.elapsed() < limit, "still running {limit:?} after the signal");
        std::thread::sleep(Duration::from_millis(20));
    }
    guard.0.take().unwrap().wait_with_output().unwrap()
}

/// SIGINT or SIGTERM while the model is still being built and compiled (a terrain of many
/// thousand cylinders makes set-up take seconds): exit 130, no run folder.
#[test]
fn a_signal_during_set_up_stops_before_the_run_folder_is_created() {
    for signal in ["TERM", "INT"] {
        let mut done = false;
        // A faster set-up (placement made quicker) needs more cylinders to still be in set-up.
        for count in [12_000, 40_000, 120_000] {
            let dir = tempfile::tempdir().unwrap();
            let guard = spawn_run(
                dir.path(),
                &[
                    "general.duration_secs=1",
                    "terrain.kind=\"random_cylinders\"",
                    &format!("terrain.random_cylinders.count={count}"),
                    "terrain.random_cylinders.half_size_m=200",
                    "terrain.random_cylinders.radius_range_m=[0.05, 0.1]",
                ],
            );
            // Give the process time to read its config and install its handler.
            std::thread::sleep(Duration::from_millis(700));
            if !run_folders(&dir.path().join("runs")).is_empty() {
                continue; // set-up was over already: try a longer one
            }
            send(guard.0.as_ref().unwrap(), signal);
            let out = finish(guard, Duration::from_secs(600));
            assert_eq!(out.status.code(), Some(130), "{signal}: {}", text(&out));
            assert!(text(&out).contains("during set-up"), "{}", text(&out));
            assert!(run_folders(&dir.path().join("runs")).is_empty(), "{signal}: a run folder was left");
            done = true;
            break;
        }
        assert!(done, "{signal}: set-up never lasted 0.7 s");
    }
}

/// SIGINT or SIGTERM during the run: exit 130, manifest `incomplete`, every table listed with
/// exactly its whole rows.
#[test]
fn a_signal_during_the_run_leaves_whole_listed_rows() {
    for signal in ["TERM", "INT"] {
        let dir = tempfile::tempdir().unwrap();
        let mut guard = spawn_run(dir.path(), &["general.duration_secs=3600", "recording.every_n_steps=1"]);
        let runs = dir.path().join("runs");
        let child = guard.0.as_mut().unwrap();
        let started = wait_until(child, || {
            run_folders(&runs)
                .first()
                .is_some_and(|r| std::fs::metadata(r.join("links.csv")).is_ok_and(|m| m.len() > 100_000))
        });
        assert!(started);
        send(guard.0.as_ref().unwrap(), signal);
        let out = finish(guard, Duration::from_secs(60));
        assert_eq!(out.status.code(), Some(130), "{signal}: {}", text(&out));
        let m = check_run_folder(&run_folders(&runs)[0], &["incomplete"], false).unwrap();
        assert_eq!(m["tables"].as_array().unwrap().len(), 4, "{m}");
    }
}

/// SIGINT or SIGTERM while `general.plot = true` draws the plots: exit 130; the manifest says
/// the run is `complete` and its `plots` says `interrupted`.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_signal_during_plotting_exits_130_and_the_manifest_says_plots_interrupted() {
    for signal in ["INT", "TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let mut guard =
            spawn_run(dir.path(), &["general.duration_secs=3", "recording.every_n_steps=1", "general.plot=true"]);
        let runs = dir.path().join("runs");
        let child = guard.0.as_mut().unwrap();
        // The manifest says `complete` before plotting starts.
        let plotting = wait_until(child, || {
            run_folders(&runs).first().is_some_and(|r| {
                std::fs::read_to_string(r.join("manifest.json")).is_ok_and(|t| t.contains("\"complete\""))
            })
        });
        assert!(plotting, "{signal}: ended before plotting");
        send(guard.0.as_ref().unwrap(), signal);
        let out = finish(guard, Duration::from_secs(120));
        let run = &run_folders(&runs)[0];
        let m = check_run_folder(run, &["complete"], false).unwrap();
        assert_eq!(out.status.code(), Some(130), "{signal}: {} {m}", text(&out));
        assert_eq!(m["plots"], "interrupted", "{m}");
        assert!(text(&out).contains("plotting interrupted"), "{}", text(&out));
    }
}

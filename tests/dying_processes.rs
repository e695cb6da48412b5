//! Dying processes and hostile surroundings (issue 17, items 7–10 and 13): closed pipes, a full
//! disk at every stage of a run, SIGKILL mid-run (CSV and Parquet), signals during set-up and
//! plotting, and sweeps resumed from their manifests.
#![allow(clippy::unwrap_used)]

use simserpent::sweep::{self, SampleMode, SweepSpec, Variation};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_simserpent")
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

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

/// Kills a child process when the test ends (also when it fails).
struct KillOnDrop(Option<Child>);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if let Some(child) = self.0.as_mut() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
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

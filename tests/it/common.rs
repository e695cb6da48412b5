//! Helpers shared by the test modules: one implementation each.

use simserpent::config::{
    Config, ConfigError, ConfigSource, DEFAULT_CONFIG_TOML, GaitKind, TerrainKind, load_config_str,
};
use simserpent::run::{self, RunOptions};
use simserpent::sim::{Simulation, Snapshot};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Gravity of the default config (m/s²).
pub const G: f64 = 9.81;

// --- files of the repository -------------------------------------------------------------------

/// The repository's root folder.
/// Writes a `w` × `h` 8-bit grayscale PNG (row by row from the image's top left), e.g. a
/// heightfield.
pub fn write_gray_png(path: &Path, w: u32, h: u32, pixels: &[u8]) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header().unwrap().write_image_data(pixels).unwrap();
}

/// [`write_gray_png`] of the gray `pixel(column, row)` gives (row 0 the image's top, column 0
/// its left).
pub fn write_gray_png_of(path: &Path, w: u32, h: u32, pixel: impl Fn(u32, u32) -> u8) {
    let pixels: Vec<u8> = (0..h).flat_map(|r| (0..w).map(move |c| (r, c))).map(|(r, c)| pixel(c, r)).collect();
    write_gray_png(path, w, h, &pixels);
}

pub fn manifest_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A file or folder under `tests/data`.
pub fn data(name: &str) -> PathBuf {
    manifest_dir().join("tests/data").join(name)
}

// --- the command line --------------------------------------------------------------------------

/// The `simserpent` binary cargo built for these tests.
pub fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_simserpent")
}

/// Runs `simserpent args…` in `dir` and waits for it.
pub fn simserpent(dir: &Path, args: &[&str]) -> Output {
    Command::new(exe()).current_dir(dir).args(args).output().unwrap()
}

/// Standard output and standard error of a finished process, as one text.
pub fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

// --- configs and runs --------------------------------------------------------------------------

/// The embedded default config with `--set` style overrides applied in order.
pub fn default_config_with(overrides: &[String]) -> Result<Config, ConfigError> {
    load_config_str(DEFAULT_CONFIG_TOML, ConfigSource::Toml, overrides)
}

/// The override that sends runs to `folder` (a temporary folder of the test).
pub fn output_dir(folder: &Path) -> String {
    format!("general.output_dir={:?}", folder.display().to_string())
}

/// The default config on a bare floor: no terrain, no gait.
pub fn bare_floor() -> Config {
    let mut c = Config::default();
    c.terrain.kind = TerrainKind::None;
    c.gait.kind = GaitKind::None;
    c
}

/// One link (the default 0.3 kg link: L = 0.2 m, r = 0.04 m) lying on a bare floor, no gait.
pub fn one_link() -> Config {
    let mut c = bare_floor();
    c.snake.n_links = 1;
    c
}

/// Runs `config` in this process (default options) and returns its run folder.
pub fn run_folder(config: &Config) -> PathBuf {
    run::run(config, &RunOptions::default()).unwrap().run_folder
}

/// Every leaf key path of a TOML table (`general.duration_secs`, …), in the table's order.
pub fn leaf_paths(table: &toml::Table) -> Vec<String> {
    fn walk(t: &toml::Table, prefix: &str, out: &mut Vec<String>) {
        for (k, v) in t {
            let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
            match v {
                toml::Value::Table(sub) => walk(sub, &path, out),
                _ => out.push(path),
            }
        }
    }
    let mut out = Vec::new();
    walk(table, "", &mut out);
    out
}

/// The state after the controller has run for the current step (the simulation does not advance).
pub fn snapshot(sim: &mut Simulation) -> Snapshot {
    let mut s = Snapshot::new(sim.world().n_links(), sim.world().n_joints());
    sim.control();
    sim.snapshot(&mut s);
    s
}

// --- run folders and their tables --------------------------------------------------------------

/// Run folders under `dir/runs`, sorted.
pub fn run_folders(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = match std::fs::read_dir(dir.join("runs")) {
        Ok(entries) => entries.map(|e| e.unwrap().path()).collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

/// A run folder's `manifest.json`.
pub fn manifest(run: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(run.join("manifest.json")).unwrap()).unwrap()
}

/// Reads a CSV table: header and rows; checks that every row has the header's width.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    split_csv(path, &std::fs::read_to_string(path).unwrap())
}

/// [`read_csv`], and checks that the table is whole: the file ends with a newline (the last row
/// is not cut off) and every row's time (the first field) parses as a finite number.
pub fn read_complete_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let content = std::fs::read_to_string(path).unwrap();
    assert!(content.ends_with('\n'), "{}: the last row is cut off", path.display());
    let (header, rows) = split_csv(path, &content);
    for (i, r) in rows.iter().enumerate() {
        let time: f64 = r[0].parse().unwrap_or_else(|_| panic!("{}: row {i} time {:?}", path.display(), r[0]));
        assert!(time.is_finite());
    }
    (header, rows)
}

fn split_csv(path: &Path, content: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = content.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(String::from).collect()).collect();
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), header.len(), "{}: row {i} has {} fields", path.display(), r.len());
    }
    (header, rows)
}

/// [`read_csv`] of a table whose every field is a number.
pub fn read_csv_numbers(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let (header, rows) = read_csv(path);
    let rows = rows.iter().map(|r| r.iter().map(|x| x.parse().unwrap()).collect()).collect();
    (header, rows)
}

// --- isolation ---------------------------------------------------------------------------------

/// Runs `body` in a child process of this test binary that runs only the test `test_name` (its
/// full name, module included: `"robustness::accepted_configs_compile_and_step"`), with a
/// temporary folder as working directory; the calling test passes when the child's test passes.
///
/// For tests that change process-wide state other tests must not see (the interrupt flag), and
/// for in-process runs: MuJoCo warnings (no log hook is installed in tests) go to `MUJOCO_LOG.TXT`
/// in the working directory, and runs go to `runs/` there, not into the repository.
pub fn in_child_process(test_name: &str, body: impl FnOnce()) {
    const CHILD: &str = "SIMSERPENT_TEST_CHILD";
    if std::env::var(CHILD).is_ok_and(|name| name == test_name) {
        body();
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", test_name, "--nocapture", "--test-threads=1"])
        .env(CHILD, test_name)
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success() && text(&out).contains("1 passed"), "{}", text(&out));
    // A child's figures (lines with "figures:", for RELIABILITY.md) on the parent's output.
    for line in text(&out).lines().filter_map(|l| l.find("figures:").map(|at| &l[at..])) {
        println!("{line}");
    }
}

/// Sets `path` = `value` in `table`, creating sections ; returns false on a clash.
pub fn set_path(table: &mut toml::Table, path: &str, value: toml::Value) -> bool {
    let mut parts: Vec<&str> = path.split('.').collect();
    let Some(last) = parts.pop() else { return false };
    let mut t = table;
    for p in parts {
        let entry = t.entry(p.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        match entry {
            toml::Value::Table(sub) => t = sub,
            _ => return false,
        }
    }
    t.insert(last.to_string(), value);
    true
}

/// Puts a 1-link snake on a slope of `angle_deg` (a 3 m × 1 m slope rising along +x from the
/// foot line at x = 1), head uphill, its centre `s_m` up the surface from the foot line; returns
/// the unit vector up the slope.
pub fn place_link_on_slope(c: &mut Config, angle_deg: f64, s_m: f64) -> [f64; 3] {
    let th = angle_deg.to_radians();
    c.terrain.slope.angle_deg = angle_deg;
    c.terrain.slope.start_m = [1.0, 0.0];
    c.terrain.slope.direction_deg = 0.0;
    c.terrain.slope.length_m = 3.0;
    c.terrain.slope.width_m = 1.0;
    let (l, r) = (c.snake.link_length_m, c.snake.link_radius_m);
    let dir = [th.cos(), 0.0, th.sin()];
    let normal = [-th.sin(), 0.0, th.cos()];
    let centre: Vec<f64> = (0..3).map(|k| [1.0, 0.0, 0.0][k] + s_m * dir[k] + r * normal[k]).collect();
    let tip: Vec<f64> = (0..3).map(|k| centre[k] + l / 2.0 * dir[k]).collect();
    c.snake.head_position_m = [tip[0], tip[1], tip[2] - r];
    c.snake.head_rotation_deg = [0.0, -angle_deg, 0.0];
    dir
}

/// The largest ratio of horizontal to vertical floor force on link 0 over the next `steps`
/// steps, each read from the snapshot of the instant (the friction coefficient a sliding link
/// meets: Coulomb friction never exceeds μ·N and equals it while sliding).
pub fn largest_floor_friction_ratio(sim: &mut Simulation, steps: usize) -> f64 {
    let mut s = Snapshot::new(1, 0);
    let mut largest: f64 = 0.0;
    for _ in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        let f = s.link_floor_force_n[0];
        if f[2] > 1e-6 {
            largest = largest.max(f[0].hypot(f[1]) / f[2]);
        }
        sim.advance().unwrap();
    }
    largest
}

/// Kills a child process when the test ends (also when it fails before the child does: a long
/// run must not outlive its test).
pub struct KillOnDrop(pub Option<std::process::Child>);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if let Some(child) = self.0.as_mut() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// A full disk, simulated with a file-size limit (`ulimit -f 100`: 100 blocks of 512 bytes, so
/// config, model and manifest fit; SIGXFSZ ignored so writes fail with EFBIG instead of killing
/// the process): runs `simserpent run --quiet` with `args` (shell words) in `dir`, and asserts
/// that the run failed with exit 1 naming a file whose name contains `file`, on stderr and in
/// the manifest.
pub fn assert_a_full_disk_fails_the_run_naming(dir: &Path, args: &str, file: &str) {
    let script = format!("ulimit -f 100 && trap '' XFSZ && exec '{}' run --quiet {args}", exe());
    let out = std::process::Command::new("sh").current_dir(dir).args(["-c", &script]).output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(stderr.contains("cannot write ") && stderr.contains(file) && stderr.contains("File too large"), "{stderr}");
    let run = &run_folders(dir)[0];
    let m = manifest(run);
    assert_eq!(m["status"], "failed");
    let error = m["error"].as_str().unwrap();
    assert!(error.contains(file) && error.contains("File too large"), "{error}");
}

/// Starts `simserpent run --quiet` in `dir` with `--set` for each of `sets`, its output piped;
/// the child is killed when the guard drops.
pub fn spawn_run(dir: &Path, sets: &[&str]) -> KillOnDrop {
    let mut command = std::process::Command::new(exe());
    command.current_dir(dir).args(["run", "--quiet"]);
    for s in sets {
        command.args(["--set", s]);
    }
    let piped = std::process::Stdio::piped;
    KillOnDrop(Some(command.stdout(piped()).stderr(piped()).spawn().unwrap()))
}

/// Waits (at most 120 s) until the run in `dir` has at least `lines` lines in `links.csv`
/// (header included) and returns its run folder; fails if the run ends by itself first.
pub fn wait_for_rows(guard: &mut KillOnDrop, dir: &Path, lines: usize) -> PathBuf {
    use std::time::{Duration, Instant};
    let child = guard.0.as_mut().unwrap();
    let started = Instant::now();
    loop {
        assert!(started.elapsed() < Duration::from_secs(120), "not {lines} lines in links.csv after 120 s");
        if let Some(run) = run_folders(dir).first()
            && std::fs::read_to_string(run.join("links.csv")).is_ok_and(|t| t.lines().count() >= lines)
        {
            return run.clone();
        }
        assert!(child.try_wait().unwrap().is_none(), "the run ended by itself");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Sends `signal` (`TERM`, `INT`, …) to the child, waits for its end (at most 60 s: the stop
/// comes within 64 steps, the rest is a loaded machine's slack) and returns its output.
pub fn signal_and_wait(mut guard: KillOnDrop, signal: &str) -> Output {
    use std::time::{Duration, Instant};
    let child = guard.0.as_mut().unwrap();
    let status = std::process::Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status();
    assert!(status.unwrap().success());
    let stopped = Instant::now();
    while child.try_wait().unwrap().is_none() {
        assert!(stopped.elapsed() < Duration::from_secs(60), "{signal}: still running 60 s after the signal");
        std::thread::sleep(Duration::from_millis(20));
    }
    guard.0.take().unwrap().wait_with_output().unwrap()
}

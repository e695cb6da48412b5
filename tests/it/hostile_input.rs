//! New inputs tried as an attacker would: range arguments that would be expanded into billions of
//! values, writers pointed through links and FIFOs (render images, sweep runs, generated guide
//! pages), input that used to be dropped silently (an external force on a link a robot does not
//! have, NaN and infinities in robot and terrain files), files given as run folders, and
//! warnings that echoed whole values. Each test prints a `figures:` line with its counts, which
//! RELIABILITY.md quotes; `scripts/red-team` reruns them by class.

use crate::common::{data, exe, run_folders, text};
use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The most bytes an error or warning may take on standard error (a message, not an echo).
const MESSAGE_CAP_BYTES: usize = 2000;

fn cli(dir: &Path, args: &[&str]) -> Output {
    Command::new(exe()).current_dir(dir).args(args).output().unwrap()
}

/// Exit code 2 at once, a message naming `needle` under [`MESSAGE_CAP_BYTES`], no panic.
fn refused(out: &Output, started: Instant, needle: &str) -> Result<(), String> {
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.code() != Some(2) {
        return Err(format!("exit {:?}: {}", out.status.code(), text(out)));
    }
    if stderr.contains("panicked") {
        return Err(format!("panic: {stderr}"));
    }
    if !stderr.contains(needle) {
        return Err(format!("no {needle:?} in: {stderr}"));
    }
    if stderr.len() > MESSAGE_CAP_BYTES {
        return Err(format!("{} bytes of stderr", stderr.len()));
    }
    // Slack for a loaded machine; a range expanded before it is checked takes minutes or aborts.
    if started.elapsed() > Duration::from_secs(60) {
        return Err(format!("took {:?}", started.elapsed()));
    }
    Ok(())
}

fn mkfifo(path: &Path) {
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success());
}

/// Runs every case (arguments, what the message must name) in `dir`; panics listing the ones
/// that were not refused cleanly, after printing the figures.
fn expect_refused(class: &str, dir: &Path, cases: &[(Vec<String>, &str)]) {
    let mut problems = Vec::new();
    for (args, needle) in cases {
        let started = Instant::now();
        let argv: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = cli(dir, &argv);
        if let Err(e) = refused(&out, started, needle) {
            let shown: String = format!("{args:?}").chars().take(300).collect();
            let e: String = e.chars().take(1000).collect();
            problems.push(format!("{shown}: {e}"));
        }
    }
    eprintln!("figures: {class}: {} cases, {} refused cleanly", cases.len(), cases.len() - problems.len());
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

fn args(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

// --- 1. ranges and counts ----------------------------------------------------------------------

/// `--seeds` ranges are counted before they are expanded; bench sizes and durations, sweep grid
/// ranges and study repeats are bounded before anything runs.
#[test]
fn range_and_count_arguments_are_bounded_before_they_are_expanded() {
    let dir = tempfile::tempdir().unwrap();
    let sweep_dir = dir.path().join("sweep").display().to_string();
    let cases = vec![
        (args(&["experiment", "estimation", "--seeds", "0-18446744073709551615"]), "give at most 10000"),
        (args(&["experiment", "estimation", "--seeds", "1-1000000000"]), "1000000000 seeds; give at most 10000"),
        (args(&["experiment", "estimation", "--seeds", "0-10000"]), "10001 seeds"),
        (args(&["experiment", "estimation", "--seeds", "0-18446744073709551616"]), "is not a seed"),
        (args(&["experiment", "estimation", "--seeds", "²"]), "is not a seed"),
        (args(&["experiment", "estimation", "--seeds", &"9".repeat(5000)]), "bytes)"),
        (args(&["experiment", "estimation", "--seeds", &vec!["1"; 10_001].join(",")]), "10001 seeds"),
        (args(&["experiment", "estimation", "--seeds", "5-3"]), "larger than its last"),
        (args(&["bench", "--links", "100000", "--duration-secs", "1"]), "--links (snake.n_links)"),
        (args(&["bench", "--links", "10", "--duration-secs", "1e300"]), "--duration-secs"),
        (args(&["bench", "--links", "10", "--duration-secs", "NaN"]), "--duration-secs"),
        (args(&["bench", "--links", "0", "--duration-secs", "1"]), "--links"),
        (args(&["sweep", "--vary", "general.seed=0:1e300:1e-300", "--sweep-dir", &sweep_dir]), "at most 1000000"),
        (args(&["sweep", "--vary", "general.seed=-1e308:1e308:1", "--sweep-dir", &sweep_dir]), "at most 1000000"),
        (args(&["sweep", "--vary", "general.seed=0:1", "--sample", "lhs", "--samples", "100000000"]), "--samples"),
        (args(&["study", "accuracy", "--repeats", "18446744073709551616"]), "repeats"),
    ];
    expect_refused("ranges and counts", dir.path(), &cases);
    assert!(!dir.path().join("sweep").exists() && !dir.path().join("runs").exists());
}

/// The library's own bound on `--seeds` (for callers that do not go through the command line)
/// and the oal-bench sizes (Rust and Python share `Bench::check`).
#[test]
fn the_library_bounds_seed_lists_and_benchmark_sizes() {
    use simserpent::experiments::oal_bench::Bench;
    use simserpent::experiments::{ExperimentOptions, MAX_SEEDS, run_experiment_with};
    let dir = tempfile::tempdir().unwrap();
    let config = simserpent::config::Config::default();
    let options = ExperimentOptions { seeds: Some((0..=MAX_SEEDS as u64).collect()), ..ExperimentOptions::default() };
    let e = run_experiment_with("estimation", &config, dir.path(), &options).err().unwrap();
    assert!(e.to_string().contains("10001 seeds; give at most 10000"), "{e}");
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "nothing is written");
    let sizes = [
        (Bench { tuning_fields: 1001, ..Bench::quick() }, "tuning fields = 1001"),
        (Bench { held_out_fields: u64::MAX, ..Bench::quick() }, "held-out fields = 18446744073709551615"),
        (Bench { held_out_fields: 0, ..Bench::quick() }, "held-out fields = 0"),
        (Bench { duration_secs: f64::NAN, ..Bench::quick() }, "duration = NaN s"),
        (Bench { floors: Vec::new(), ..Bench::quick() }, "at least one floor"),
    ];
    for (bench, needle) in &sizes {
        let e = bench.check().err().unwrap();
        assert!(e.to_string().contains(needle), "{e}");
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let out = dir.path().join("oal");
    let e = simserpent::experiments::oal_bench::run_into(&sizes[1].0, &config, &pool, &out, "", false).err().unwrap();
    assert!(e.to_string().contains("held-out fields"), "{e}");
    assert!(!out.exists(), "no folder for a refused benchmark");
    assert!(Bench::quick().check().is_ok() && Bench::full().check().is_ok());
    eprintln!("figures: library bounds: {} cases refused", 2 + sizes.len());
}

// --- 2. writers ----------------------------------------------------------------------------------

fn quick_run(dir: &Path, sets: &[&str]) -> PathBuf {
    let mut argv = vec![
        "run".to_string(),
        "--quiet".into(),
        "--set".into(),
        "general.duration_secs=0.05".into(),
        "--set".into(),
        "snake.n_links=3".into(),
        "--set".into(),
        format!("general.output_dir=\"{}\"", dir.join("runs").display()),
    ];
    for s in sets {
        argv.push("--set".into());
        argv.push(s.to_string());
    }
    let a: Vec<&str> = argv.iter().map(String::as_str).collect();
    let out = cli(dir, &a);
    assert!(out.status.success(), "{}", text(&out));
    run_folders(dir).pop().unwrap()
}

/// `render --images` into a linked `images/` (or onto a linked image or video), a sweep whose
/// `runs/` (or one run's folder) is a link, `doc-gen` onto linked pages, a FIFO page and a page
/// linked to `/dev/zero`: refused (exit 2) and nothing written or read outside.
#[test]
fn writers_never_write_through_links_and_doc_gen_reads_like_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let outside = tempfile::tempdir().unwrap();
    let o = outside.path();
    let d = dir.path();
    let mut problems = Vec::new();
    let mut cases = 0;
    let mut check = |what: &str, out: Output, needle: &str| {
        cases += 1;
        if let Err(e) = refused(&out, Instant::now(), needle) {
            problems.push(format!("{what}: {e}"));
        }
    };

    // render: the run folder's own `images/` linked out, or one image file linked out.
    let run = quick_run(d, &["render.record_state=true"]);
    let r = run.to_str().unwrap();
    let times = "render.image_times_secs=[0.02]";
    symlink(o, run.join("images")).unwrap();
    check("render, linked images/", cli(d, &["render", r, "--images", "--set", times]), "images is a symbolic link");
    std::fs::remove_file(run.join("images")).unwrap();
    std::fs::create_dir(run.join("images")).unwrap();
    for camera in ["follow", "top", "side", "overview"] {
        symlink(o.join("planted.png"), run.join("images").join(format!("{camera}_0.020s.png"))).unwrap();
    }
    let rendered = cli(d, &["render", r, "--images", "--set", times]);
    // A build without a renderer refuses before any image (exit 2 or 1 naming the renderer).
    if !String::from_utf8_lossy(&rendered.stderr).contains("offscreen rendering is not available") {
        check("render, a linked image", rendered, "is a symbolic link");
    }
    std::fs::remove_dir_all(run.join("images")).unwrap();
    for name in ["video_follow.mp4", "video_follow.gif"] {
        symlink(o.join("planted.mp4"), run.join(name)).unwrap();
    }
    let rendered = cli(d, &["render", r, "--video"]);
    if !String::from_utf8_lossy(&rendered.stderr).contains("offscreen rendering is not available") {
        check("render, a linked video", rendered, "is a symbolic link");
    }

    // sweep: `runs/` linked out; one planned run's folder linked out.
    let sweep = d.join("sweep");
    std::fs::create_dir(&sweep).unwrap();
    symlink(o, sweep.join("runs")).unwrap();
    let s = sweep.to_str().unwrap();
    let sweep_args = ["sweep", "--vary", "general.seed=1,2", "--set", "general.duration_secs=0.02", "--quiet"];
    let mut a = sweep_args.to_vec();
    a.extend(["--sweep-dir", s]);
    check("sweep, linked runs/", cli(d, &a), "runs is a symbolic link");

    // doc-gen: a page linked out (dangling), to /dev/zero, a FIFO; the folder a file.
    let pages = d.join("pages");
    std::fs::create_dir(&pages).unwrap();
    let p = pages.to_str().unwrap();
    symlink(o.join("config.md"), pages.join("config.md")).unwrap();
    check("doc-gen, a page linked out", cli(d, &["doc-gen", p]), "is a symbolic link");
    std::fs::remove_file(pages.join("config.md")).unwrap();
    symlink("/dev/zero", pages.join("config.md")).unwrap();
    check("doc-gen --check, a page linked to /dev/zero", cli(d, &["doc-gen", p, "--check"]), "/dev/zero");
    check("doc-gen, a page linked to /dev/zero", cli(d, &["doc-gen", p]), "is a symbolic link");
    std::fs::remove_file(pages.join("config.md")).unwrap();
    mkfifo(&pages.join("config.md"));
    check("doc-gen --check, a FIFO page", cli(d, &["doc-gen", p, "--check"]), "is a FIFO");
    check("doc-gen, a FIFO page", cli(d, &["doc-gen", p]), "is a FIFO");
    std::fs::remove_file(pages.join("config.md")).unwrap();
    check("doc-gen, not a folder", cli(d, &["doc-gen", run.join("config.toml").to_str().unwrap()]), "not a folder");
    // The same folder with plain pages: written, then equal.
    let ok = cli(d, &["doc-gen", p]);
    assert!(ok.status.success(), "{}", text(&ok));
    let ok = cli(d, &["doc-gen", p, "--check"]);
    assert!(ok.status.success(), "{}", text(&ok));

    let leaked: Vec<_> = std::fs::read_dir(o).unwrap().flatten().map(|e| e.path()).collect();
    eprintln!("figures: writers through links: {cases} cases, {} refused cleanly", cases - problems.len());
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(leaked.is_empty(), "written outside: {leaked:?}");
}

/// A planted link at one planned run's name is neither read as a finished run nor written
/// through: that run fails naming the link, the others complete.
#[test]
fn a_sweep_run_folder_linked_out_fails_alone() {
    let dir = tempfile::tempdir().unwrap();
    let outside = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep");
    let s = sweep.to_str().unwrap();
    let base = ["sweep", "--vary", "general.seed=1,2", "--set", "general.duration_secs=0.02", "--set"];
    let mut a = base.to_vec();
    a.extend(["snake.n_links=3", "--quiet", "--sweep-dir", s]);
    let first = cli(dir.path(), &a);
    assert!(first.status.success(), "{}", text(&first));
    let runs: Vec<PathBuf> = std::fs::read_dir(sweep.join("runs")).unwrap().flatten().map(|e| e.path()).collect();
    assert_eq!(runs.len(), 2);
    // The first run's folder replaced by a link to a (complete) copy outside.
    let copy = outside.path().join("copy");
    assert!(Command::new("cp").arg("-r").arg(&runs[0]).arg(&copy).status().unwrap().success());
    std::fs::remove_dir_all(&runs[0]).unwrap();
    symlink(&copy, &runs[0]).unwrap();
    let before = std::fs::read(copy.join("manifest.json")).unwrap();
    let again = cli(dir.path(), &a);
    assert_eq!(again.status.code(), Some(1), "{}", text(&again));
    assert!(String::from_utf8_lossy(&again.stderr).contains("is a symbolic link"), "{}", text(&again));
    assert_eq!(std::fs::read(copy.join("manifest.json")).unwrap(), before, "the link's target is untouched");
    eprintln!("figures: sweep run linked out: 1 case, failed alone naming the link");
}

// --- 3. nothing dropped --------------------------------------------------------------------------

/// An external force on a link a `--robot` does not have is refused naming the key, the value
/// and the robot's links; NaN, infinities and overflowing numbers in a URDF's `<limit>` and
/// `<origin>`, an MJCF robot's attributes and a third-party terrain are refused naming the line,
/// element, attribute and value.
#[test]
fn forces_on_missing_links_and_non_finite_numbers_in_robot_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out_dir = format!("general.output_dir=\"{}\"", d.join("runs").display());
    let urdf = std::fs::read_to_string(data("two_link.urdf")).unwrap();
    let mjcf = std::fs::read_to_string(data("two_link_arm.xml")).unwrap();
    let force = |link: usize| {
        let config = d.join(format!("force{link}.toml"));
        std::fs::write(
            &config,
            format!(
                "[[physics.external_forces]]\nlink = {link}\ndirection = [1.0, 0.0, 0.0]\nstart_secs = 0.0\n\
                 ramp_n_per_s = 0.0\nforce_n = 1.0\nduration_secs = 0.0\n"
            ),
        )
        .unwrap();
        config.display().to_string()
    };
    let robot = data("two_link.urdf").display().to_string();
    let servos = "robot.position_servos=true";
    let short = "general.duration_secs=0.05";
    let mut cases: Vec<(Vec<String>, &str)> = Vec::new();
    for link in [2, 5, 1_000_000] {
        let config = force(link);
        cases.push((
            args(&["run", &config, "--robot", &robot, "--set", servos, "--set", short, "--set", &out_dir, "--quiet"]),
            "physics.external_forces[0].link` = ",
        ));
    }
    let bad_files: Vec<(&str, String, &str)> = vec![
        ("limit_nan.urdf", urdf.replace("upper=\"1\"", "upper=\"nan\""), "<limit upper=\"nan\">"),
        ("limit_inf.urdf", urdf.replace("lower=\"-1\"", "lower=\"-inf\""), "<limit lower=\"-inf\">"),
        ("origin_nan.urdf", urdf.replace("xyz=\"0.1 0 0.5\"", "xyz=\"0.1 NaN 0.5\""), "<origin xyz=\"0.1 NaN 0.5\">"),
        ("origin_big.urdf", urdf.replace("xyz=\"0.1 0 0.5\"", "xyz=\"1e999 0 0.5\""), "<origin xyz=\"1e999 0 0.5\">"),
        ("mass_inf.urdf", urdf.replace("value=\"0.5\"", "value=\"infinity\""), "<mass value=\"infinity\">"),
        ("range_nan.xml", mjcf.replace("range=\"-1 1\"", "range=\"-1 nan\""), "<joint range=\"-1 nan\">"),
        ("pos_inf.xml", mjcf.replace("pos=\"0.1 0 0\"", "pos=\"0.1 0 inf\""), "<body pos=\"0.1 0 inf\">"),
        ("kp_nan.xml", mjcf.replace("kp=\"5\"", "kp=\"NAN\""), "<position kp=\"NAN\">"),
    ];
    for (name, text, needle) in &bad_files {
        std::fs::write(d.join(name), text).unwrap();
        cases.push((
            args(&["run", "--robot", name, "--set", servos, "--set", short, "--set", &out_dir, "--quiet"]),
            needle,
        ));
    }
    // A joint named `inf` is a name, not a number.
    std::fs::write(d.join("named_inf.urdf"), urdf.replace("name=\"elbow\"", "name=\"inf\"")).unwrap();
    let named =
        cli(d, &["run", "--robot", "named_inf.urdf", "--set", servos, "--set", short, "--set", &out_dir, "--quiet"]);
    assert!(named.status.success(), "{}", text(&named));
    // A third-party terrain with a NaN.
    let terrain_dir = d.join("terrain");
    std::fs::create_dir(&terrain_dir).unwrap();
    std::fs::write(
        terrain_dir.join("t.xml"),
        "<mujoco><worldbody><geom name=\"rock\" type=\"box\" size=\"0.1 0.1 nan\" pos=\"1 0 0\"/></worldbody></mujoco>\n",
    )
    .unwrap();
    let terrain = format!("terrain.include_mjcf=\"{}\"", terrain_dir.join("t.xml").display());
    cases.push((args(&["check", "--set", &terrain]), "<geom size=\"0.1 0.1 nan\">"));
    expect_refused("nothing dropped", d, &cases);
    assert!(!d.join("runs").exists() || run_folders(d).len() == 1, "only the accepted run left a folder");
    // The scanner itself: line numbers, names skipped, a clean file passes.
    use simserpent::model::files::first_non_finite_number;
    let found = first_non_finite_number(b"<a>\n<b name=\"nan\" x=\"1\"/>\n\n<c y=\"2 -INF\"/></a>").unwrap();
    assert_eq!((found.line, found.element.as_str(), found.attribute.as_str()), (4, "c", "y"));
    assert!(first_non_finite_number(urdf.as_bytes()).is_none());
    assert!(first_non_finite_number(mjcf.as_bytes()).is_none());
}

// --- 4. exit codes -------------------------------------------------------------------------------

/// `plot`, `render`, `estimate` and `bag-repair` given a file, a FIFO, a device or a missing path
/// as the run folder: exit code 2 naming it.
#[test]
fn a_run_folder_argument_that_is_no_folder_is_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("afile"), "x").unwrap();
    mkfifo(&d.join("fifo"));
    let mut cases = Vec::new();
    for command in ["plot", "render", "estimate", "bag-repair"] {
        for (path, needle) in [
            ("afile", "afile is a regular file, not a folder"),
            ("fifo", "fifo is a FIFO, not a folder"),
            ("/dev/null", "/dev/null is a device, not a folder"),
            ("missing", "RUN_FOLDER missing is missing"),
            ("afile/x", "not a folder"),
        ] {
            let mut a = vec![command, path];
            if command == "render" {
                a.push("--images");
            }
            cases.push((args(&a), needle));
        }
    }
    expect_refused("run folder arguments", d, &cases);
}

// --- 5. echoes -----------------------------------------------------------------------------------

/// A warning about a 10,000-element list and messages about a robot with a 100,000-character
/// joint name echo each value as errors do (at most 200 characters).
#[test]
fn warnings_and_robot_messages_echo_values_as_errors_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let list = vec!["1.0"; 10_000].join(", ");
    std::fs::write(d.join("pattern.toml"), format!("[gait.form_closure]\npattern_deg = [{list}]\n")).unwrap();
    let out = cli(d, &["check", "pattern.toml"]);
    assert!(out.status.success(), "{}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("pattern_deg = [1.0, 1.0") && stderr.contains("(50000 bytes) has no effect"), "{stderr}");
    assert!(stderr.len() < MESSAGE_CAP_BYTES, "{} bytes", stderr.len());

    let urdf = std::fs::read_to_string(data("two_link.urdf")).unwrap();
    let long = "j".repeat(100_000);
    std::fs::write(d.join("long.urdf"), urdf.replace("name=\"elbow\"", &format!("name=\"{long}\""))).unwrap();
    let out_dir = format!("general.output_dir=\"{}\"", d.join("runs").display());
    let mut sizes = Vec::new();
    // The servos' tracking warning names the joint; the run starts at the full command (no
    // ramp-in, within which a run gets no tracking verdict).
    for sets in [&[][..], &["gait.kind=\"none\""][..], &["robot.position_servos=true", "gait.ramp_secs=0.0"][..]] {
        let mut a = vec!["run", "--robot", "long.urdf", "--quiet", "--set", "general.duration_secs=0.05", "--set"];
        a.push(&out_dir);
        for s in sets {
            a.extend(["--set", *s]);
        }
        let out = cli(d, &a);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            !stderr.contains("panicked") && stderr.contains("jjjj"),
            "{sets:?}: {}",
            &stderr[..stderr.len().min(500)]
        );
        assert!(stderr.len() < MESSAGE_CAP_BYTES, "{sets:?}: {} bytes of stderr", stderr.len());
        sizes.push(stderr.len());
    }
    eprintln!(
        "figures: echoes: a 10,000-element list warning in {} bytes; a 100,000-character joint name in {sizes:?} bytes of stderr (error, note, warning)",
        stderr.len()
    );
}

// --- 6. robot size -------------------------------------------------------------------------------

/// A URDF chain of `n` links (0.1 m each, a cylinder and revolute joints with limits), as a
/// user's long robot would be.
fn urdf_chain(n: usize) -> String {
    urdf_robot("chain", n, |i| (i - 1, "0.1 0 0".to_string()))
}

/// A URDF of `n` links all on one base (cylinders 0.1 m apart on a grid of 100 columns,
/// revolute joints with limits): many links, none on a long chain.
fn urdf_star(n: usize) -> String {
    urdf_robot("star", n, |i| (0, format!("{:.1} {:.1} 0", (i % 100) as f64 * 0.1, (i / 100) as f64 * 0.1)))
}

/// A URDF robot of `n` cylinder links; `joint(i)` gives link i's parent and its joint's origin
/// (x y z) for i ≥ 1.
fn urdf_robot(name: &str, n: usize, joint: impl Fn(usize) -> (usize, String)) -> String {
    let mut out = format!("<?xml version=\"1.0\"?>\n<robot name=\"{name}\">\n");
    for i in 0..n {
        out.push_str(&format!(
            "<link name=\"link_{i}\"><inertial><origin xyz=\"0.05 0 0\"/><mass value=\"0.1\"/><inertia ixx=\"1e-4\" \
             ixy=\"0\" ixz=\"0\" iyy=\"1e-4\" iyz=\"0\" izz=\"1e-4\"/></inertial><collision><origin xyz=\"0.05 0 0\" \
             rpy=\"0 1.5707963 0\"/><geometry><cylinder radius=\"0.02\" length=\"0.06\"/></geometry></collision></link>\n"
        ));
    }
    for i in 1..n {
        let (parent, origin) = joint(i);
        out.push_str(&format!(
            "<joint name=\"joint_{i}\" type=\"revolute\"><parent link=\"link_{parent}\"/><child link=\"link_{i}\"/><origin \
             xyz=\"{origin}\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"5\" velocity=\"2\"/></joint>\n"
        ));
    }
    out.push_str("</robot>\n");
    out
}

/// An MJCF chain of `n` nested bodies.
fn mjcf_chain(n: usize) -> String {
    let mut out = String::from("<mujoco><worldbody>\n");
    for i in 0..n {
        out.push_str(&format!(
            "<body name=\"b{i}\" pos=\"0.1 0 0\"><joint name=\"j{i}\" type=\"hinge\" axis=\"0 0 1\"/><geom type=\"capsule\" \
             fromto=\"0 0 0 0.08 0 0\" size=\"0.02\"/>\n"
        ));
    }
    out.push_str(&"</body>".repeat(n));
    out.push_str("\n</worldbody></mujoco>\n");
    out
}

/// Writes each robot file into `d`, runs it, and expects every run refused at once with its
/// message, no run folder left; prints the class's figures.
fn run_robots_expecting_refusal<const N: usize>(label: &str, d: &Path, robots: [(&str, String, &str); N]) {
    let out_dir = format!("general.output_dir=\"{}\"", d.join("runs").display());
    let mut cases = Vec::new();
    for (name, text, needle) in robots {
        std::fs::write(d.join(name), text).unwrap();
        cases.push((
            args(&["run", "--robot", name, "--quiet", "--set", "gait.kind=\"none\"", "--set", &out_dir]),
            needle,
        ));
    }
    let started = Instant::now();
    expect_refused(label, d, &cases);
    eprintln!("figures: {label}: {} refused in {:.2} s", cases.len(), started.elapsed().as_secs_f64());
    assert!(!d.join("runs").exists());
}

/// Robots with more links in all than the documented cap (2,000), none on a long chain, are
/// refused at once, before MuJoCo reads them (a 5,000-link one took 7.5 s of CPU time to set up,
/// 10,000 links 34 s: MuJoCo's set-up grows with about the square of the links), naming the
/// number of links and the cap.
#[test]
fn robots_with_more_links_than_the_cap_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // An MJCF robot of 2,001 bodies side by side (each a child of the world).
    let mut flat = String::from("<mujoco><worldbody>\n");
    for i in 0..2001 {
        flat.push_str(&format!(
            "<body name=\"b{i}\" pos=\"{:.1} 0 0.1\"><geom type=\"sphere\" size=\"0.02\"/></body>\n",
            i as f64 * 0.1
        ));
    }
    flat.push_str("</worldbody></mujoco>\n");
    run_robots_expecting_refusal(
        "robots beyond the link cap",
        d,
        [
            ("star2001.urdf", urdf_star(2001), "it has 2001 links; a robot may have at most 2000 links"),
            ("star10000.urdf", urdf_star(10_000), "it has 10000 links; a robot may have at most 2000 links"),
            ("flat2001.xml", flat, "it has 2001 links; a robot may have at most 2000 links"),
        ],
    );
    use simserpent::model::files::{MAX_ROBOT_LINKS, scan_robot_file};
    assert_eq!(MAX_ROBOT_LINKS, 2000);
    let star = scan_robot_file(urdf_star(2000).as_bytes());
    assert_eq!((star.links, star.longest_chain_links), (2000, 2));
    assert_eq!(scan_robot_file(urdf_chain(30).as_bytes()).links, 30);
    assert_eq!(scan_robot_file(mjcf_chain(7).as_bytes()).links, 7);
}

/// Robots with a chain longer than the documented cap (400 links) are refused at once, before
/// MuJoCo reads them (a 1,000-link chain failed after three compiles; a 10,000-link one gave no
/// answer in 120 s), naming the chain's length, its last link and the cap.
#[test]
fn robots_with_chains_beyond_the_cap_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run_robots_expecting_refusal(
        "robot chains beyond the cap",
        d,
        [
            ("chain401.urdf", urdf_chain(401), "401 links (to `link_400`)"),
            ("chain1000.urdf", urdf_chain(1000), "1000 links (to `link_999`)"),
            ("chain10000.urdf", urdf_chain(10_000), "10000 links (to `link_9999`)"),
            ("chain401.xml", mjcf_chain(401), "401 links (to `b400`)"),
        ],
    );
    use simserpent::model::files::{MAX_ROBOT_CHAIN_LINKS, scan_robot_file};
    assert_eq!(MAX_ROBOT_CHAIN_LINKS, 400);
    let urdf = scan_robot_file(urdf_chain(400).as_bytes());
    assert_eq!((urdf.longest_chain_links, urdf.deepest_link.as_str()), (400, "link_399"));
    assert_eq!(scan_robot_file(mjcf_chain(7).as_bytes()).longest_chain_links, 7);
    // A tree: two branches of 3 from a base are 4 links on the longest chain.
    let tree = "<robot name=\"t\"><link name=\"base\"/><link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>\
                <link name=\"d\"/><link name=\"e\"/><link name=\"f\"/>\
                <joint name=\"1\" type=\"fixed\"><parent link=\"base\"/><child link=\"a\"/></joint>\
                <joint name=\"2\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\
                <joint name=\"3\" type=\"fixed\"><parent link=\"b\"/><child link=\"c\"/></joint>\
                <joint name=\"4\" type=\"fixed\"><parent link=\"base\"/><child link=\"d\"/></joint>\
                <joint name=\"5\" type=\"fixed\"><parent link=\"d\"/><child link=\"e\"/></joint>\
                <joint name=\"6\" type=\"fixed\"><parent link=\"e\"/><child link=\"f\"/></joint></robot>";
    assert_eq!(scan_robot_file(tree.as_bytes()).longest_chain_links, 4);
    // A cycle (no root) ends.
    let cycle = "<robot name=\"c\"><link name=\"a\"/><link name=\"b\"/>\
                 <joint name=\"1\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\
                 <joint name=\"2\" type=\"fixed\"><parent link=\"b\"/><child link=\"a\"/></joint></robot>";
    assert!(scan_robot_file(cycle.as_bytes()).longest_chain_links <= 3);
}

/// A chain at the cap (400 links) loads, sets up and runs (slow: a long chain's steps are costly).
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_robot_chain_at_the_cap_runs() {
    run_robot_expecting_completion("chain400.urdf", &urdf_chain(400));
}

/// A robot at the link cap (2,000 links on one base) loads, sets up and runs (slow: MuJoCo's
/// set-up of 2,000 links takes about a second of CPU time in a release build).
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_robot_at_the_link_cap_runs() {
    run_robot_expecting_completion("star2000.urdf", &urdf_star(2000));
}

/// Writes the robot file `name` and runs it for 10 ms without a gait or terrain: it completes.
fn run_robot_expecting_completion(name: &str, robot: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join(name), robot).unwrap();
    let out_dir = format!("general.output_dir=\"{}\"", d.join("runs").display());
    let out = cli(
        d,
        &[
            "run",
            "--robot",
            name,
            "--quiet",
            "--set",
            "gait.kind=\"none\"",
            "--set",
            "terrain.kind=\"none\"",
            "--set",
            "general.duration_secs=0.01",
            "--set",
            &out_dir,
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(crate::common::manifest(&run_folders(d)[0])["status"], "complete");
}

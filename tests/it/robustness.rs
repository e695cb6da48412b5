//! Never lose a run: bad configs (a corpus and random configs), bad robot files,
//! divergence (NaN, MuJoCo warnings, runaway energy), interruption by SIGINT/SIGTERM, output
//! problems (unwritable folder, full disk), determinism, and the documented exit codes.

use crate::common::{
    assert_a_full_disk_fails_the_run_naming, data, in_child_process, leaf_paths, manifest, manifest_dir,
    read_complete_csv, run_folders, set_path, signal_and_wait, simserpent, spawn_run, text, wait_for_rows,
};
use proptest::prelude::*;
use simserpent::config::{self, Config, ConfigSource};
use simserpent::sim::{SimError, Simulation, World};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

// --- 1. bad configs: the corpus -------------------------------------------------------------

fn corpus_dir() -> PathBuf {
    manifest_dir().join("tests/bad_configs")
}

/// (file name, expected substrings), from `tests/bad_configs/expected.toml`.
fn corpus() -> Vec<(String, Vec<String>)> {
    let dir = corpus_dir();
    let expected: toml::Table = std::fs::read_to_string(dir.join("expected.toml")).unwrap().parse().unwrap();
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name != "expected.toml")
        .collect();
    files.sort();
    let listed: Vec<&String> = expected.keys().collect();
    for name in &files {
        assert!(expected.contains_key(name), "tests/bad_configs/{name} has no entry in expected.toml");
    }
    for name in &listed {
        assert!(files.contains(name), "expected.toml lists {name}, which is not in tests/bad_configs/");
    }
    files
        .into_iter()
        .map(|name| {
            let needles = expected[&name].as_array().unwrap().iter().map(|v| v.as_str().unwrap().to_string()).collect();
            (name, needles)
        })
        .collect()
}

#[test]
fn bad_config_corpus_has_at_least_40_files_and_each_gives_its_error() {
    let corpus = corpus();
    assert!(corpus.len() >= 40, "only {} broken configs", corpus.len());
    let mut problems = Vec::new();
    for (name, needles) in &corpus {
        let path = corpus_dir().join(name);
        let message = match config::load_config(&path, &[]) {
            Err(e) => e.to_string(),
            Ok(cfg) => match simserpent::model::generate(&cfg) {
                Err(simserpent::model::ModelError::Config(e)) => e.to_string(),
                Err(other) => {
                    problems.push(format!("{name}: model generation failed without a key: {other}"));
                    continue;
                }
                Ok(_) => {
                    problems.push(format!("{name}: accepted"));
                    continue;
                }
            },
        };
        for needle in needles {
            if !message.contains(needle.as_str()) {
                problems.push(format!("{name}: error lacks {needle:?}: {message}"));
            }
        }
    }
    assert!(problems.is_empty(), "{} problems:\n{}", problems.len(), problems.join("\n"));
}

#[test]
fn bad_config_corpus_exits_2_through_the_cli_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    for (name, needles) in corpus() {
        let path = corpus_dir().join(&name);
        let out_file = dir.path().join("out.xml");
        let out = simserpent(dir.path(), &["model", path.to_str().unwrap(), "-o", out_file.to_str().unwrap()]);
        if out.status.code() != Some(2) {
            problems.push(format!("{name}: exit code {:?}: {}", out.status.code(), text(&out)));
        }
        let stderr = String::from_utf8_lossy(&out.stderr);
        if !stderr.contains(name.as_str()) {
            problems.push(format!("{name}: stderr does not name the file: {stderr}"));
        }
        if !stderr.starts_with("error: ") {
            problems.push(format!("{name}: stderr does not start with `error: `: {stderr}"));
        }
        for needle in &needles {
            if !stderr.contains(needle.as_str()) {
                problems.push(format!("{name}: stderr lacks {needle:?}: {stderr}"));
            }
        }
        if out_file.exists() {
            problems.push(format!("{name}: wrote a model"));
        }
    }
    assert!(problems.is_empty(), "{} problems:\n{}", problems.len(), problems.join("\n"));
    // `run` on configs rejected by validation and by model generation: exit 2, no run folder.
    for name in ["nan_timestep.toml", "contradiction_obstacle_inside_snake.toml", "empty.json"] {
        let out = simserpent(dir.path(), &["run", corpus_dir().join(name).to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2), "{name}: {}", text(&out));
    }
    assert!(run_folders(dir.path()).is_empty(), "no run folder for bad input");
}

// --- 1. bad configs: random configs -----------------------------------------------------------

/// Every leaf key path of the default config (`general.duration_secs`, ...).
fn leaf_keys() -> Vec<String> {
    leaf_paths(&config::DEFAULT_CONFIG_TOML.parse().unwrap())
}

/// Every leaf key path of the original tool's config.json (tests/data/thesis_config.json).
fn legacy_keys() -> Vec<String> {
    fn walk(v: &serde_json::Value, prefix: &str, out: &mut Vec<String>) {
        if let serde_json::Value::Object(map) = v {
            for (k, v) in map {
                let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                if v.is_object() { walk(v, &path, out) } else { out.push(path) }
            }
        }
    }
    let text = std::fs::read_to_string(data("thesis_config.json")).unwrap();
    let mut out = Vec::new();
    walk(&serde_json::from_str(&text).unwrap(), "", &mut out);
    out
}

fn any_value() -> impl Strategy<Value = toml::Value> {
    let float = prop_oneof![
        any::<f64>(),
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(0.0),
        Just(-0.0),
        -10.0..10.0f64,
        Just(1e300),
        Just(-1e-300),
    ];
    let leaf = prop_oneof![
        float.clone().prop_map(toml::Value::Float),
        prop_oneof![any::<i64>(), -3..300i64].prop_map(toml::Value::Integer),
        any::<bool>().prop_map(toml::Value::Boolean),
        prop_oneof![
            "[a-z_]{0,12}",
            Just("RK4".to_string()),
            Just("sine_wave".to_string()),
            Just("../x".to_string()),
            ".{0,8}"
        ]
        .prop_map(toml::Value::String),
    ];
    leaf.prop_recursive(2, 12, 5, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..6).prop_map(toml::Value::Array),
            prop::collection::btree_map("[a-z_]{1,8}", inner, 0..3)
                .prop_map(|m| toml::Value::Table(m.into_iter().collect())),
        ]
    })
}

/// A key path: a real one, a real one misspelt, or a random one.
fn any_key(keys: Vec<String>) -> impl Strategy<Value = String> {
    let n = keys.len();
    let real = keys.clone();
    prop_oneof![
        4 => (0..n).prop_map(move |i| real[i].clone()),
        1 => (0..n, 0..20usize, "[a-z_]").prop_map(move |(i, at, c)| {
            let mut k = keys[i].clone();
            let at = at.min(k.len());
            if k.is_char_boundary(at) {
                k.insert_str(at, &c);
            }
            k
        }),
        1 => "[a-z_]{1,8}(\\.[a-z_]{1,8}){0,2}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]

    /// Random keys and values of every type through loading, validation and model generation:
    /// no panic, and every rejection is a config error with a key, a file position or a message.
    #[test]
    #[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
    fn random_configs_never_panic(entries in prop::collection::vec((any_key(leaf_keys()), any_value()), 0..8)) {
        let mut table = toml::Table::new();
        for (key, value) in entries {
            set_path(&mut table, &key, value);
        }
        let text = toml::to_string(&table).unwrap_or_default();
        if let Ok(cfg) = config::load_config_str(&text, ConfigSource::Toml, &[]) {
            // Accepted configs must generate or be rejected with a key (never panic).
            match simserpent::model::generate(&cfg) {
                Ok(_) | Err(simserpent::model::ModelError::Config(_)) => {}
                Err(other) => prop_assert!(false, "{text}: {other}"),
            }
        }
        // The same values as `--set` overrides.
        let overrides: Vec<String> = text.lines().filter(|l| l.contains('=')).map(String::from).collect();
        let _ = config::load_config_str("", ConfigSource::Toml, &overrides);
    }

    /// The original tool's config.json with random values (of every JSON type) at its real keys:
    /// converted, validated and generated without a panic.
    #[test]
    fn random_legacy_json_never_panics(entries in prop::collection::vec((any_key(legacy_keys()), any_value()), 0..8)) {
        let mut table = toml::Table::new();
        for (key, value) in entries {
            set_path(&mut table, &key, value);
        }
        // NaN and infinities have no JSON form: serde_json writes them as null.
        let json = serde_json::to_string(&table).unwrap_or_default();
        if let Ok(cfg) = config::load_config_str(&json, ConfigSource::LegacyJson, &[]) {
            match simserpent::model::generate(&cfg) {
                Ok(_) | Err(simserpent::model::ModelError::Config(_)) => {}
                Err(other) => prop_assert!(false, "{json}: {other}"),
            }
        }
    }

    /// Arbitrary text as TOML and as the original tool's JSON: an error, never a panic.
    #[test]
    fn random_text_never_panics(text in ".{0,200}") {
        let _ = config::load_config_str(&text, ConfigSource::Toml, &[]);
        let _ = config::load_config_str(&text, ConfigSource::LegacyJson, &[]);
        let _ = config::parse_override(&text);
    }
}

/// A config within the documented ranges, as `--set` overrides.
fn valid_overrides() -> impl Strategy<Value = Vec<String>> {
    let snake = (1..=14usize, 0.01..0.08f64, 1.0..3.0f64, 0.05..2.0f64, 20.0..180.0f64, 0.0..0.6f64);
    let pose = (0.0..0.3f64, -180.0..180.0f64, prop::bool::ANY, prop::bool::ANY, prop::bool::ANY);
    let kinds = (0..4usize, 0..4usize, 0..3usize, 0..5usize, 0..2usize, 0..4usize, 0..2usize);
    let numbers = (0..4usize, 1.0..3.0f64, 0.0..1.0f64, 0.1..3.0f64, 0.0..90.0f64, 0..=i64::MAX as u64);
    (snake, pose, kinds, numbers).prop_map(
        |((n, r, len_factor, mass, range, amp_frac), (z, yaw, noise, selfc, pyramidal), k, nums)| {
            let (integrator, method, gait, terrain, axes, ground, friction) = k;
            let (dt_i, tc_factor, damping, freq, phase, seed) = nums;
            let dt: f64 = [0.0005, 0.001, 0.002, 0.005][dt_i];
            let gait_name = ["none", "sine_wave", "form_closure"][gait];
            let mut o = vec![
                "general.duration_secs=0.05".to_string(),
                "recording.enabled=false".to_string(),
                format!("general.timestep_secs={dt}"),
                format!("general.seed={seed}"),
                format!("general.integrator=\"{}\"", ["Euler", "RK4", "implicit", "implicitfast"][integrator]),
                format!("physics.contact_time_constant_secs={}", (2.0 * dt).max(0.01) * tc_factor),
                format!("physics.friction_cone=\"{}\"", if pyramidal { "pyramidal" } else { "elliptic" }),
                format!("physics.self_collision={selfc}"),
                format!("snake.n_links={n}"),
                format!("snake.link_radius_m={r}"),
                format!("snake.link_length_m={}", 2.0 * r * len_factor),
                format!("snake.link_mass_kg={mass}"),
                format!("snake.joint_range_deg={range}"),
                format!("snake.joint_damping_nm_s_per_rad={damping}"),
                format!("snake.joint_axes=\"{}\"", ["yaw", "alternating"][axes]),
                format!("snake.head_position_m=[0.0, 0.0, {z}]"),
                format!("snake.head_rotation_deg=[0.0, 0.0, {yaw}]"),
                format!("sensors.noise_enabled={noise}"),
                format!("control.method=\"{}\"", ["torque", "position", "velocity", "intvelocity"][method]),
                format!("gait.kind=\"{gait_name}\""),
                format!("gait.sine_wave.amplitude_deg={}", range * amp_frac),
                format!("gait.sine_wave.frequency_hz={freq}"),
                format!("gait.sine_wave.phase_lag_deg={phase}"),
                format!("gait.form_closure.pattern_deg=[0.0, {a}, {a}, 0.0, -{a}, -{a}]", a = range * amp_frac * 0.9),
                format!(
                    "terrain.kind=\"{}\"",
                    ["none", "two_cylinders", "random_cylinders", "cylinder_path", "form_closure"][terrain]
                ),
                format!("ground.model=\"{}\"", ["isotropic", "anisotropic", "directional", "viscous"][ground]),
                format!("snake.ground_friction=[{}, 0.0, 0.0]", [0.0, 0.5][friction]),
            ];
            o.push("terrain.random_cylinders.count=5".to_string());
            o
        },
    )
}

/// Configs within the documented ranges: whatever validation and model generation accept,
/// MuJoCo compiles, and it steps (a diverging step is an error, never a crash).
#[test]
fn accepted_configs_compile_and_step() {
    in_child_process("robustness::accepted_configs_compile_and_step", || {
        let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
            cases: 40,
            failure_persistence: None,
            ..ProptestConfig::default()
        });
        let result = runner.run(&valid_overrides(), |overrides| {
            let cfg: Config = match config::load_config_str("", ConfigSource::Toml, &overrides) {
                Ok(c) => c,
                Err(_) => return Ok(()), // rejected with a message: fine
            };
            match World::from_config(&cfg) {
                Ok(world) => {
                    let mut sim = Simulation::new(&cfg, world);
                    for _ in 0..20 {
                        if sim.step().is_err() {
                            break;
                        }
                    }
                }
                Err(SimError::Config(_)) => {} // rejected by model generation, with a key
                Err(other) => prop_assert!(false, "accepted config does not compile: {other}\n{overrides:#?}"),
            }
            Ok(())
        });
        if let Err(e) = result {
            panic!("{e}");
        }
    });
}

// --- 2. bad robot files -----------------------------------------------------------------------

#[test]
fn bad_robot_files_exit_2_naming_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let short = ["--set", "general.duration_secs=0.05"];
    let cases: [(&str, &[&str], &[&str]); 9] = [
        ("missing_robot.xml", &[], &["missing_robot.xml", "does not exist"]),
        ("robot_malformed.xml", &[], &["robot_malformed.xml", "XML_ERROR_MISMATCHED_ELEMENT", "Line number="]),
        ("robot_malformed.urdf", &[], &["robot_malformed.urdf", "XML"]),
        ("robot_empty.xml", &[], &["robot_empty.xml", "empty file"]),
        ("robot_unknown_element.xml", &[], &["robot_unknown_element.xml", "unrecognized element", "wheel"]),
        ("robot_missing_mesh.xml", &[], &["robot_missing_mesh.xml", "meshes/hull.stl"]),
        ("robot_missing_texture.xml", &[], &["robot_missing_texture.xml", "textures/skin.png"]),
        ("robot_no_actuator.xml", &[], &["robot_no_actuator.xml", "joint `elbow` has no actuator", "sine_wave"]),
        ("robot_no_joints.xml", &["--set", "gait.kind=\"form_closure\""], &["robot_no_joints.xml", "no hinge"]),
    ];
    for (file, extra, needles) in cases {
        let robot = data(file).to_str().unwrap().to_string();
        let args = [&["run", "--robot", robot.as_str()][..], &short, extra].concat();
        let out = simserpent(dir.path(), &args);
        assert_eq!(out.status.code(), Some(2), "{file}: {}", text(&out));
        for needle in needles {
            assert!(text(&out).contains(needle), "{file}: lacks {needle:?}: {}", text(&out));
        }
    }
    assert!(run_folders(dir.path()).is_empty(), "no run folder for a bad robot");
    // Without a gait, robots without actuators (or joints) run.
    for file in ["robot_no_actuator.xml", "robot_no_joints.xml", "two_link.urdf"] {
        let robot = data(file).to_str().unwrap().to_string();
        let out =
            simserpent(dir.path(), &[&["run", "--robot", &robot, "--set", "gait.kind=\"none\""][..], &short].concat());
        assert!(out.status.success(), "{file}: {}", text(&out));
    }
    // A robot with an actuator on every joint runs with a gait.
    let out =
        simserpent(dir.path(), &[&["run", "--robot", data("two_link_arm.xml").to_str().unwrap()][..], &short].concat());
    assert!(out.status.success(), "{}", text(&out));
}

// --- 3. divergence ----------------------------------------------------------------------------

/// Semi-implicit Euler at 10 ms with a stiff position servo (and no torque limit): the joint
/// oscillation grows by an order of magnitude every few steps; nothing is NaN yet when the
/// energy passes any physical value.
const UNSTABLE: [&str; 12] = [
    "--set",
    "general.timestep_secs=0.01",
    "--set",
    "general.integrator=\"Euler\"",
    "--set",
    "control.position_kp_nm_per_rad=500",
    "--set",
    "snake.torque_range_nm=[-1e9, 1e9]",
    "--set",
    "terrain.kind=\"none\"",
    "--set",
    "recording.every_n_steps=1",
];

#[test]
fn runaway_energy_stops_the_run_with_time_step_and_cause_and_keeps_the_tables() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &[&["run", "--quiet"][..], &UNSTABLE].concat());
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    for needle in ["simulation diverged at t = ", "(step ", "runaway energy", "safety.max_kinetic_energy_j_per_kg"] {
        assert!(stderr.contains(needle), "lacks {needle:?}: {stderr}");
    }
    let run = &run_folders(dir.path())[0];
    let m = manifest(run);
    assert_eq!(m["status"], "failed");
    let error = m["error"].as_str().unwrap();
    assert!(error.contains("runaway energy") && error.contains("step "), "{error}");
    // Everything recorded up to the failure is there, complete and finite.
    let step_failed = m["steps"].as_u64().unwrap();
    assert!(step_failed > 5, "the energy grew over several steps, got {step_failed}");
    let (_, rows) = read_complete_csv(&run.join("links.csv"));
    assert_eq!(rows.len() as u64, step_failed, "one row per step before the failing one");
    assert_eq!(m["tables"][0][0], "links.csv");
    assert_eq!(m["tables"][0][1].as_u64().unwrap(), rows.len() as u64);
    for row in &rows {
        assert!(row.iter().skip(1).all(|v| v.parse::<f64>().unwrap().is_finite()), "{row:?}");
    }
}

#[test]
fn without_the_energy_guard_mujoco_warnings_or_nan_stop_the_same_run_later() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(
        dir.path(),
        &[&["run", "--quiet"][..], &UNSTABLE, &["--set", "safety.max_kinetic_energy_j_per_kg=0"]].concat(),
    );
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(stderr.contains("simulation diverged at t = ") && !stderr.contains("runaway energy"), "{stderr}");
    assert!(stderr.contains("mjWARN_BADQACC") || stderr.contains("not finite"), "{stderr}");
    let run = &run_folders(dir.path())[0];
    assert_eq!(manifest(run)["status"], "failed");
    read_complete_csv(&run.join("joints.csv"));
}

#[test]
fn the_energy_guard_does_not_trip_on_a_normal_run_and_checks_at_its_interval() {
    // The default run with the check at every step, and a bound just above what a gentle
    // undulation reaches.
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "run",
        "--quiet",
        "--set",
        "general.duration_secs=0.5",
        "--set",
        "safety.check_every_n_steps=1",
        "--set",
        "recording.enabled=false",
    ];
    let out = simserpent(dir.path(), &args);
    assert!(out.status.success(), "{}", text(&out));
    // A tiny bound trips on the first checked step: step 7 with every 7 steps.
    let args =
        [&args[..], &["--set", "safety.max_kinetic_energy_j_per_kg=1e-12", "--set", "safety.check_every_n_steps=7"]]
            .concat();
    let out = simserpent(dir.path(), &args);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("(step 7): runaway energy"), "{}", text(&out));
}

/// A controller that sends NaN after 0.1 s (a user's bug).
struct NanAfter {
    secs: f64,
}

impl simserpent::control::Controller for NanAfter {
    fn update(&mut self, obs: &simserpent::control::Observation, cmd: &mut simserpent::control::Command) {
        let value = if obs.time_secs >= self.secs { f64::NAN } else { 0.0 };
        cmd.position_rad.fill(value);
    }
}

#[test]
fn a_controller_that_sends_nan_fails_the_run_instead_of_being_silently_zeroed() {
    in_child_process("robustness::a_controller_that_sends_nan_fails_the_run_instead_of_being_silently_zeroed", || {
        let overrides: Vec<String> = ["general.duration_secs=1", "recording.every_n_steps=1", "terrain.kind=\"none\""]
            .map(String::from)
            .to_vec();
        let cfg = config::load_config_str("", ConfigSource::Toml, &overrides).unwrap();
        let options = simserpent::run::RunOptions::default();
        let err = simserpent::run::run_with_controller(&cfg, &options, Box::new(NanAfter { secs: 0.1 })).unwrap_err();
        assert!(matches!(err, simserpent::run::RunError::Sim(simserpent::sim::SimError::Diverged { .. })), "{err}");
        let message = err.to_string();
        assert!(message.contains("mjWARN_BADCTRL") && message.contains("t = 0.101"), "{message}");
        let run = &run_folders(&std::env::current_dir().unwrap())[0];
        assert_eq!(manifest(run)["status"], "failed");
        let (_, rows) = read_complete_csv(&run.join("joints.csv"));
        assert_eq!(rows.len(), 101, "steps 0..=100 were recorded before the failing step");
    });
}

// --- 4. interruption --------------------------------------------------------------------------

fn interrupt_with(signal: &str) {
    let dir = tempfile::tempdir().unwrap();
    let mut guard = spawn_run(dir.path(), &["general.duration_secs=3600"]);
    // Wait until rows have reached links.csv (the header and at least two rows).
    let run = wait_for_rows(&mut guard, dir.path(), 3);
    let out = signal_and_wait(guard, signal);
    assert_eq!(out.status.code(), Some(130), "{signal}: {}", text(&out));
    assert!(text(&out).contains("interrupted"), "{}", text(&out));
    let m = manifest(&run);
    assert_eq!(m["status"], "incomplete", "{signal}");
    let reason = m["error"].as_str().unwrap();
    assert!(reason.contains("interrupted by a signal") && reason.contains("step "), "{reason}");
    let steps = m["steps"].as_u64().unwrap();
    assert!(steps > 0 && steps < 3_600_000);
    // Every table is complete and readable, and holds the rows the manifest counts.
    for (i, table) in ["links.csv", "joints.csv", "sensors.csv", "contacts.csv"].into_iter().enumerate() {
        let (_, rows) = read_complete_csv(&run.join(table));
        assert_eq!(m["tables"][i][0], table);
        assert_eq!(m["tables"][i][1].as_u64().unwrap(), rows.len() as u64, "{table}");
    }
    // Recorded every n steps from step 0; the stop comes after the row of its step.
    let every = m["record_every_n_steps"].as_u64().unwrap();
    let (_, rows) = read_complete_csv(&run.join("links.csv"));
    assert_eq!(rows.len() as u64, steps / every + 1, "steps {steps}");
}

#[test]
fn sigterm_stops_the_run_cleanly_with_exit_130() {
    interrupt_with("TERM");
}

#[test]
fn sigint_stops_the_run_cleanly_with_exit_130() {
    interrupt_with("INT");
}

// --- 5. output problems -----------------------------------------------------------------------

#[test]
fn an_unwritable_output_folder_fails_at_once_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("somefile"), "not a folder").unwrap();
    // Permission bits do not stop root; a path below a regular file, or in /proc, stops anyone.
    for (output_dir, needle) in [("somefile/runs", "Not a directory"), ("/proc/simserpent-runs", "/proc")] {
        let started = Instant::now();
        let out = simserpent(
            dir.path(),
            &["run", "--set", &format!("general.output_dir=\"{output_dir}\""), "--set", "general.duration_secs=60"],
        );
        assert_eq!(out.status.code(), Some(1), "{}", text(&out));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(&format!("cannot write {output_dir}")) && stderr.contains(needle), "{stderr}");
        assert!(started.elapsed() < Duration::from_secs(20), "the error comes before the simulation");
    }
}

/// A full disk, simulated with a file-size limit (`ulimit -f`, SIGXFSZ ignored so writes fail
/// with EFBIG instead of killing the process): the run fails with exit 1 naming the table.
#[test]
fn a_full_disk_fails_the_run_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    assert_a_full_disk_fails_the_run_naming(dir.path(), "--set general.duration_secs=5", ".csv");
}

/// Unmounts a test's tmpfs when the test ends (also when it fails).
struct Unmount(PathBuf);

impl Drop for Unmount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// A really full disk (a 256 KiB tmpfs, when this process may mount one; skipped otherwise): the
/// run fails with exit 1 naming the table and "No space left", and the manifest — replaced
/// atomically, in the space the run folder reserved at its start — says "failed" and why.
#[test]
fn a_really_full_disk_fails_the_run_and_the_manifest_still_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let mount_point = dir.path().join("tiny");
    std::fs::create_dir(&mount_point).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=256k", "tmpfs", mount_point.to_str().unwrap()])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        eprintln!("skipped: cannot mount a tmpfs here (needs root); the file-size-limit test covers write errors");
        return;
    }
    let _unmount = Unmount(mount_point.clone());
    let out = simserpent(&mount_point, &["run", "--quiet", "--set", "general.duration_secs=5"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(stderr.contains(".csv") && stderr.contains("No space left"), "{stderr}");
    let run = &run_folders(&mount_point)[0];
    let m = manifest(run);
    assert_eq!(m["status"], "failed");
    assert!(m["error"].as_str().unwrap().contains("No space left"), "{m}");
    assert!(!run.join("manifest.json.tmp").exists());
}

// --- 6. determinism ---------------------------------------------------------------------------

#[test]
fn random_terrain_and_noise_are_reproducible_and_follow_the_seed() {
    let dir = tempfile::tempdir().unwrap();
    let args = |seed: u64| -> Vec<String> {
        [
            "run",
            "--quiet",
            "--set",
            "general.duration_secs=0.3",
            "--set",
            "terrain.kind=\"random_cylinders\"",
            "--set",
            "terrain.random_cylinders.half_size_m=1.0",
            "--set",
            "sensors.noise_enabled=true",
            "--set",
            "recording.every_n_steps=5",
            "--set",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([format!("general.seed={seed}")])
        .collect()
    };
    for seed in [7, 7, 8] {
        let a = args(seed);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let out = simserpent(dir.path(), &a);
        assert!(out.status.success(), "{}", text(&out));
    }
    let folders = run_folders(dir.path());
    assert_eq!(folders.len(), 3);
    let seed_of = |run: &PathBuf| manifest(run)["seed"].as_u64().unwrap();
    let (sevens, eights): (Vec<&PathBuf>, Vec<&PathBuf>) = folders.iter().partition(|r| seed_of(r) == 7);
    assert_eq!((sevens.len(), eights.len()), (2, 1));
    let read = |run: &PathBuf, file: &str| std::fs::read(run.join(file)).unwrap();
    for file in ["model.xml", "links.csv", "joints.csv", "sensors.csv", "contacts.csv"] {
        assert!(read(sevens[0], file) == read(sevens[1], file), "{file} differs between identical runs");
    }
    assert!(read(sevens[0], "model.xml") != read(eights[0], "model.xml"), "another seed, another terrain");
    assert!(read(sevens[0], "sensors.csv") != read(eights[0], "sensors.csv"), "another seed, other noise");
}

// --- 7. exit codes ----------------------------------------------------------------------------

#[test]
fn exit_codes_are_documented_in_help_and_readme() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &["--help"]);
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in ["Exit codes", "0 success", "1 the simulation failed", "2 bad input", "130 interrupted"] {
        assert!(help.contains(needle), "--help lacks {needle:?}: {help}");
    }
    let readme = std::fs::read_to_string(manifest_dir().join("README.md")).unwrap();
    // The paragraph that starts with "Exit codes:".
    let start = readme.find("Exit codes:").unwrap();
    let exit_codes = &readme[start..start + readme[start..].find("\n\n").unwrap()];
    for code in ["`0`", "`1`", "`2`", "`130`"] {
        assert!(exit_codes.contains(code), "README lacks exit code {code}: {exit_codes}");
    }
    // Command-line usage errors are bad input too.
    assert_eq!(simserpent(dir.path(), &["run", "--no-such-flag"]).status.code(), Some(2));
}

//! Values that MuJoCo rejects are config errors naming the key
//! (exit code 2), runs that would never end are refused, set-up shows progress, error messages
//! stay short and say where; and the fuzz target config text → validated config → MJCF →
//! MuJoCo compile.

use proptest::prelude::*;
use simserpent::config::{self, ConfigError, ConfigSource};
use simserpent::model::{self, ModelError};
use simserpent::sim::{SimError, World};
use std::path::PathBuf;
use std::process::Output;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use crate::common::{in_child_process, manifest_dir, set_path, simserpent};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

// --- item 6: values MuJoCo rejects ------------------------------------------------------------

/// Every numeric leaf of `table`: (key path, element index for arrays, whether a float).
fn numeric_leaves(t: &toml::Table, prefix: &str, out: &mut Vec<(String, Option<usize>, bool)>) {
    for (k, v) in t {
        let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        match v {
            toml::Value::Table(sub) => numeric_leaves(sub, &path, out),
            toml::Value::Float(_) => out.push((path, None, true)),
            toml::Value::Integer(_) => out.push((path, None, false)),
            toml::Value::Array(items) => {
                for (i, e) in items.iter().enumerate() {
                    match e {
                        toml::Value::Float(_) => out.push((path.clone(), Some(i), true)),
                        toml::Value::Integer(_) => out.push((path.clone(), Some(i), false)),
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
}

fn leaf_mut<'a>(t: &'a mut toml::Table, path: &str) -> &'a mut toml::Value {
    let parts: Vec<&str> = path.split('.').collect();
    let mut cur = t;
    for p in &parts[..parts.len() - 1] {
        cur = cur.get_mut(*p).unwrap().as_table_mut().unwrap();
    }
    cur.get_mut(parts[parts.len() - 1]).unwrap()
}

/// What became of a config text: rejected with a message naming a key or file, compiled, or a
/// failure (a rejection that names neither, or MuJoCo rejecting a validated config).
#[derive(Debug, PartialEq)]
enum Outcome {
    Rejected,
    Compiled,
    Skipped,
    Failure(String),
}

/// Most obstacles a model may have to be compiled here (MuJoCo takes seconds for 100,000).
const COMPILE_AT_MOST_OBSTACLES: usize = 2000;

fn key_error_ok(e: &ConfigError) -> Result<(), String> {
    let message = e.to_string();
    let named = match e {
        ConfigError::UnknownKey { key, .. } | ConfigError::InvalidValue { key, .. } => !key.is_empty(),
        ConfigError::FileUnreadable { key, .. } => !key.is_empty(),
        ConfigError::Syntax { file, .. } => !file.is_empty(),
        ConfigError::Io { .. } => true,
        _ => false,
    };
    if !named {
        return Err(format!("names no key or file: {message}"));
    }
    // Short messages: values are echoed up to 200 characters.
    if message.len() > 4000 {
        return Err(format!("a message of {} bytes", message.len()));
    }
    Ok(())
}

fn outcome(text: &str, source: ConfigSource) -> Outcome {
    let cfg = match config::load_config_str(text, source, &[]) {
        Ok(cfg) => cfg,
        Err(e) => return key_error_ok(&e).map_or_else(Outcome::Failure, |()| Outcome::Rejected),
    };
    let generated = match model::generate(&cfg) {
        Ok(g) => g,
        Err(ModelError::Config(e)) => return key_error_ok(&e).map_or_else(Outcome::Failure, |()| Outcome::Rejected),
        Err(other) => return Outcome::Failure(format!("model generation: {other}")),
    };
    if generated.obstacles.len() + generated.features.pegs.len() > COMPILE_AT_MOST_OBSTACLES {
        return Outcome::Skipped;
    }
    match World::from_generated(&cfg, generated) {
        Ok(_) => Outcome::Compiled,
        Err(SimError::Config(e)) => key_error_ok(&e).map_or_else(Outcome::Failure, |()| Outcome::Rejected),
        Err(other) => Outcome::Failure(format!("a validated config does not compile: {other}")),
    }
}

/// The probe of the red-team pass, kept as a test: every numeric key of the default config at
/// its extremes is rejected naming its key, or compiles; nothing panics and MuJoCo never
/// rejects a validated config.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn every_numeric_key_at_its_extremes_is_rejected_naming_it_or_compiles() {
    in_child_process("limits::every_numeric_key_at_its_extremes_is_rejected_naming_it_or_compiles", || {
        let base: toml::Table = config::DEFAULT_CONFIG_TOML.parse().unwrap();
        let mut keys = Vec::new();
        numeric_leaves(&base, "", &mut keys);
        let floats = [0.0, -0.0, 1e-308, -1e-308, 5e-324, 1e-14, 1e-300, 1e300, -1e300, f64::MAX, 1e-7, 1e12];
        let ints = [0, -1, i64::from(i32::MAX) + 1, i64::from(u32::MAX) + 1, i64::MAX];
        let (mut cases, mut rejected, mut compiled) = (0, 0, 0);
        let mut failures = Vec::new();
        for (key, index, is_float) in keys {
            let values: Vec<toml::Value> = if is_float {
                floats.iter().map(|v| toml::Value::Float(*v)).collect()
            } else {
                ints.iter().map(|v| toml::Value::Integer(*v)).collect()
            };
            for value in values {
                let mut t = base.clone();
                let slot = leaf_mut(&mut t, &key);
                match index {
                    Some(i) => slot.as_array_mut().unwrap()[i] = value.clone(),
                    None => *slot = value.clone(),
                }
                cases += 1;
                let text = toml::to_string(&t).unwrap();
                match std::panic::catch_unwind(|| outcome(&text, ConfigSource::Toml)) {
                    Ok(Outcome::Rejected) => rejected += 1,
                    Ok(Outcome::Compiled | Outcome::Skipped) => compiled += 1,
                    Ok(Outcome::Failure(why)) => failures.push(format!("{key}{index:?} = {value}: {why}")),
                    Err(_) => failures.push(format!("{key}{index:?} = {value}: panic")),
                }
            }
        }
        println!(
            "figures: extremes per key: {cases} cases, {rejected} rejected naming the key, {compiled} compile, {} failures",
            failures.len()
        );
        assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
    });
}

#[test]
fn values_mujoco_rejected_exit_2_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("physics.solver_iterations=2147483648", "physics.solver_iterations"),
        ("snake.link_mass_kg=1e-14", "snake.link_mass_kg"),
        ("snake.link_mass_kg=1e308", "snake.link_mass_kg"),
        ("snake.link_length_m=1e300", "snake.link_length_m"),
        ("snake.joint_damping_nm_s_per_rad=1e-308", "snake.joint_damping_nm_s_per_rad"),
        ("general.gravity_m_per_s2=[0.0, 1e-308, -9.81]", "general.gravity_m_per_s2"),
        ("terrain.cylinder_path.start_m=1e-308", "terrain.cylinder_path.start_m"),
        ("snake.color_rgba=[1e-300, 0.2, 1.0, 1.0]", "snake.color_rgba"),
    ];
    for (set, key) in cases {
        let out = simserpent(dir.path(), &["run", "--set", set, "--set", "general.duration_secs=0.01"]);
        assert_eq!(out.status.code(), Some(2), "{set}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(err.contains(key) && !err.contains("MuJoCo rejected"), "{set}: {err}");
    }
    assert!(!dir.path().join("runs").exists(), "no run folder for bad input");
}

/// A config built in code (the Python package) may hold counts above i64::MAX, which TOML
/// cannot: the check of every number must still see the subnormal.
#[test]
fn a_seed_above_i64_max_does_not_hide_a_subnormal_value() {
    let mut cfg = config::load_config_str("", ConfigSource::Toml, &[]).unwrap();
    cfg.general.seed = u64::MAX;
    cfg.snake.joint_armature_kg_m2 = 1e-310;
    let e = cfg.validate().unwrap_err();
    assert!(e.to_string().contains("snake.joint_armature_kg_m2") && e.to_string().contains("subnormal"), "{e}");
}

/// A third-party terrain that passes SimSerpent's checks but that MuJoCo rejects: exit 2,
/// MuJoCo's whole message (not cut at 100 characters), the user's own file named, not the
/// scratch copy.
#[test]
fn a_terrain_mujoco_rejects_exits_2_with_the_whole_message_and_the_users_path() {
    let dir = tempfile::tempdir().unwrap();
    let name = "a_geom_with_a_long_name_so_that_the_message_of_mujoco_is_longer_than_a_hundred_characters";
    let terrain = dir.path().join("my_terrain.xml");
    std::fs::write(
        &terrain,
        format!("<mujoco>\n  <worldbody>\n    <geom name=\"{name}\" type=\"box\" size=\"1 1\" pos=\"5 5 0\"/>\n  </worldbody>\n</mujoco>\n"),
    )
    .unwrap();
    let set = format!("terrain.include_mjcf=\"{}\"", terrain.display());
    let out = simserpent(dir.path(), &["run", "--set", &set, "--set", "general.duration_secs=0.01"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("MuJoCo rejected the model with the third-party terrain"), "{err}");
    assert!(err.contains(name), "the whole message: {err}");
    assert!(err.contains(&terrain.display().to_string()), "the user's path: {err}");
    assert!(!err.contains("simserpent-model-"), "no scratch path: {err}");
    assert!(!dir.path().join("runs").exists());
}

#[test]
fn sweep_merge_of_a_missing_folder_and_init_into_a_missing_folder_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &["sweep-merge", "NONEXISTENT"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("NONEXISTENT"), "{}", stderr(&out));
    let out = simserpent(dir.path(), &["init", "nodir/x.toml"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("nodir"), "{}", stderr(&out));
    assert!(!dir.path().join("nodir").exists());
}

// --- item 11: valid configs that look like hangs ----------------------------------------------

#[test]
fn runs_that_would_never_end_are_refused_at_once_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("general.duration_secs=1e12", "general.duration_secs", "1e9 steps"),
        ("general.timestep_secs=1e-300", "general.timestep_secs", "at least 1e-7 s"),
        ("physics.solver_iterations=1000000000", "physics.solver_iterations", "at most 100000"),
    ];
    for (set, key, allowed) in cases {
        let start = Instant::now();
        let out = simserpent(dir.path(), &["run", "--set", set]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{set}: {err}");
        assert!(err.contains(key) && err.contains(allowed), "{set}: {err}");
        assert!(start.elapsed() < Duration::from_secs(30), "{set}: {:?}", start.elapsed());
    }
}

#[test]
fn setup_progress_draws_nothing_off_a_terminal_and_stops_when_dropped() {
    let start = Instant::now();
    let progress = simserpent::setup_progress::SetupProgress::start(true, "generating the model");
    progress.phase("compiling the model (MuJoCo)");
    drop(progress);
    assert!(start.elapsed() < simserpent::setup_progress::SHOW_AFTER);
}

// --- item 12: messages ------------------------------------------------------------------------

#[test]
fn a_huge_value_is_echoed_shortened_with_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("big.toml");
    let name = "x/".repeat(2_000_000); // 4 MB, not a folder name
    std::fs::write(&file, format!("[general]\nrun_name = \"{name}\"\n")).unwrap();
    let out = simserpent(dir.path(), &["check", file.to_str().unwrap()]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{}", &err[..err.len().min(500)]);
    assert!(err.len() < 2000, "{} bytes on stderr", err.len());
    assert!(err.contains("general.run_name") && err.contains("(4000002 bytes)"), "{err}");
}

#[test]
fn an_invalid_utf8_byte_is_located_by_offset_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("c.toml");
    std::fs::write(&file, b"[snake]\nn_links = 4\nlink_mass_kg = 0.3 # caf\xe9\n").unwrap();
    let out = simserpent(dir.path(), &["check", file.to_str().unwrap()]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("byte 0xE9 at byte offset 44 (line 3, column 25)"), "{err}");
}

#[test]
fn an_out_of_range_json_number_names_its_key() {
    let text = "{\n  \"snake_specifications\": {\n    \"link_radius_in_m\": -1e999\n  }\n}\n";
    let e = config::load_config_str(text, ConfigSource::LegacyJson, &[]).unwrap_err();
    let message = e.to_string();
    assert!(message.contains("snake_specifications.link_radius_in_m"), "{message}");
    assert!(message.contains("-1e999") && message.contains("line 3"), "{message}");
}

#[test]
fn a_robot_that_is_a_device_is_not_said_to_be_missing() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &["run", "--robot", "/dev/null", "--set", "general.duration_secs=0.01"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("/dev/null") && err.contains("not a regular file") && !err.contains("does not exist"),
        "{err}"
    );
    let out = simserpent(dir.path(), &["run", "--robot", "missing.xml", "--set", "general.duration_secs=0.01"]);
    assert!(stderr(&out).contains("does not exist"), "{}", stderr(&out));
}

// --- the fuzz target ----------------------------------------------------------------------------

/// Seeds: the default config, the original tool's config.json and every file of the bad-config
/// corpus, as (text, syntax).
fn seeds() -> Vec<(String, ConfigSource)> {
    let mut out = vec![
        (config::DEFAULT_CONFIG_TOML.to_string(), ConfigSource::Toml),
        (
            std::fs::read_to_string(manifest_dir().join("tests/data/thesis_config.json")).unwrap(),
            ConfigSource::LegacyJson,
        ),
    ];
    let corpus = manifest_dir().join("tests/bad_configs");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&corpus).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    for f in files {
        if f.file_name().is_some_and(|n| n == "expected.toml") {
            continue;
        }
        let text = String::from_utf8_lossy(&std::fs::read(&f).unwrap()).into_owned();
        let source =
            if f.extension().is_some_and(|e| e == "json") { ConfigSource::LegacyJson } else { ConfigSource::Toml };
        out.push((text, source));
    }
    out
}

/// Every leaf of the default config: key path and default value.
fn leaves() -> Vec<(String, toml::Value)> {
    fn walk(t: &toml::Table, prefix: &str, out: &mut Vec<(String, toml::Value)>) {
        for (k, v) in t {
            let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
            match v {
                toml::Value::Table(sub) => walk(sub, &path, out),
                _ => out.push((path, v.clone())),
            }
        }
    }
    let mut out = Vec::new();
    walk(&config::DEFAULT_CONFIG_TOML.parse().unwrap(), "", &mut out);
    out
}

fn extreme_int() -> impl Strategy<Value = i64> {
    prop_oneof![
        Just(0i64),
        Just(-1),
        Just(i64::from(i32::MAX) + 1),
        Just(i64::MAX),
        Just(100_000),
        Just(200),
        0..300i64
    ]
}

fn extreme_float() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(-0.0),
        Just(1e-308),
        Just(-1e-308),
        Just(5e-324),
        Just(2.3e-308),
        Just(1e-14),
        Just(1e-300),
        Just(1e300),
        Just(-1e300),
        Just(f64::MAX),
        Just(1e12),
        Just(1e-12),
        Just(f64::NAN),
        Just(f64::INFINITY),
        any::<f64>(),
        -10.0..10.0f64,
        0.0..1e-6f64,
    ]
}

fn any_value() -> impl Strategy<Value = toml::Value> {
    let leaf = prop_oneof![
        4 => extreme_float().prop_map(toml::Value::Float),
        2 => extreme_int().prop_map(toml::Value::Integer),
        1 => any::<bool>().prop_map(toml::Value::Boolean),
        1 => prop_oneof!["[a-z_]{0,12}", Just("RK4".to_string()), Just("random_cylinders".to_string()), ".{0,8}"]
            .prop_map(toml::Value::String),
    ];
    leaf.prop_recursive(1, 6, 4, |inner| prop::collection::vec(inner, 0..5).prop_map(toml::Value::Array))
}

/// A value of the default's type (a float for a float, one element changed in an array of
/// floats, ...) most of the time, any value otherwise.
fn value_like(default: toml::Value) -> impl Strategy<Value = toml::Value> {
    let typed = (extreme_float(), extreme_int(), any::<usize>()).prop_map(move |(f, i, at)| match &default {
        toml::Value::Float(_) => toml::Value::Float(f),
        toml::Value::Integer(_) => toml::Value::Integer(i),
        toml::Value::Array(items) if !items.is_empty() => {
            let mut items = items.clone();
            let k = at % items.len();
            items[k] = match items[k] {
                toml::Value::Integer(_) => toml::Value::Integer(i),
                _ => toml::Value::Float(f),
            };
            toml::Value::Array(items)
        }
        other => other.clone(),
    });
    prop_oneof![4 => typed, 1 => any_value()]
}

/// One change to a config: a value at a real (or misspelt) key, or a few bytes of text.
#[derive(Debug, Clone)]
enum Mutation {
    Set { key: String, misspell: Option<(usize, char)>, value: toml::Value },
    Text { at: usize, delete: usize, insert: String },
}

fn mutation(leaves: Vec<(String, toml::Value)>) -> impl Strategy<Value = Mutation> {
    let n = leaves.len();
    prop_oneof![
        6 => (0..n, prop::option::weighted(0.1, (0..30usize, prop::char::range('a', 'z'))))
            .prop_flat_map(move |(i, misspell)| {
                let key = leaves[i].0.clone();
                value_like(leaves[i].1.clone()).prop_map(move |value| Mutation::Set { key: key.clone(), misspell, value })
            }),
        1 => (any::<usize>(), 0..4usize, prop_oneof![Just(String::new()), ".{0,3}", Just("e999".to_string()), Just("\u{FFFD}".to_string())])
            .prop_map(|(at, delete, insert)| Mutation::Text { at, delete, insert }),
    ]
}

fn apply(text: &str, source: ConfigSource, m: &Mutation) -> String {
    match m {
        Mutation::Set { key, misspell, value } => {
            let mut key = key.clone();
            if let Some((at, c)) = misspell {
                let at = (*at).min(key.len());
                if key.is_char_boundary(at) {
                    key.insert(at, *c);
                }
            }
            match source {
                ConfigSource::Toml => {
                    let Ok(mut table) = text.parse::<toml::Table>() else { return text.to_string() };
                    set_path(&mut table, &key, value.clone());
                    toml::to_string(&table).unwrap_or_else(|_| text.to_string())
                }
                ConfigSource::LegacyJson => {
                    // The original tool's keys are not SimSerpent's: set the value at the JSON
                    // key of the same place in the file (a random top-level or nested key).
                    let Ok(mut json) = serde_json::from_str::<serde_json::Value>(text) else { return text.to_string() };
                    let value = serde_json::to_value(value).unwrap_or(serde_json::Value::Null);
                    if let Some(map) = json.as_object_mut() {
                        let keys: Vec<String> = map.keys().cloned().collect();
                        if !keys.is_empty() {
                            let k = &keys[key.len() % keys.len()];
                            match map.get_mut(k) {
                                Some(serde_json::Value::Object(inner)) if !inner.is_empty() => {
                                    let ks: Vec<String> = inner.keys().cloned().collect();
                                    let ik = ks[key.len() % ks.len()].clone();
                                    inner.insert(ik, value);
                                }
                                _ => {
                                    map.insert(k.clone(), value);
                                }
                            }
                        }
                    }
                    serde_json::to_string_pretty(&json).unwrap_or_else(|_| text.to_string())
                }
            }
        }
        Mutation::Text { at, delete, insert } => {
            if text.is_empty() {
                return insert.clone();
            }
            let mut at = at % text.len();
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            let mut end = (at + delete).min(text.len());
            while !text.is_char_boundary(end) {
                end += 1;
            }
            format!("{}{insert}{}", &text[..at], &text[end..])
        }
    }
}

/// Cases of the fuzz target: 256, or `SIMSERPENT_FUZZ_CASES` for longer local runs.
fn fuzz_cases() -> u32 {
    std::env::var("SIMSERPENT_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)
}

static FUZZ_REJECTED: AtomicUsize = AtomicUsize::new(0);
static FUZZ_COMPILED: AtomicUsize = AtomicUsize::new(0);
static FUZZ_SKIPPED: AtomicUsize = AtomicUsize::new(0);

/// The fuzz target: config text (a seed with 1 to 4 mutations) → validated config → generated
/// MJCF → MuJoCo compile. Every input is rejected with a config error naming a key or file,
/// or compiles; never a panic, never MuJoCo rejecting a validated config.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn fuzz_config_text_to_mujoco_compile() {
    in_child_process("limits::fuzz_config_text_to_mujoco_compile", || {
        let seeds = seeds();
        let n_seeds = seeds.len();
        // Mostly the default config (seed 0) and the original tool's config.json (seed 1).
        let seed = prop_oneof![4 => Just(0usize), 1 => Just(1usize), 2 => 0..n_seeds];
        let strategy = (seed, prop::collection::vec(mutation(leaves()), 1..4));
        let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
            cases: fuzz_cases(),
            failure_persistence: None,
            ..ProptestConfig::default()
        });
        let result = runner.run(&strategy, |(seed, mutations)| {
            let (text, source) = &seeds[seed];
            let mut text = text.clone();
            for m in &mutations {
                text = apply(&text, *source, m);
            }
            match outcome(&text, *source) {
                Outcome::Rejected => FUZZ_REJECTED.fetch_add(1, Ordering::Relaxed),
                Outcome::Compiled => FUZZ_COMPILED.fetch_add(1, Ordering::Relaxed),
                Outcome::Skipped => FUZZ_SKIPPED.fetch_add(1, Ordering::Relaxed),
                Outcome::Failure(why) => {
                    let shown: String = text.chars().take(3000).collect();
                    return Err(TestCaseError::fail(format!("{why}\n--- input:\n{shown}")));
                }
            };
            Ok(())
        });
        println!(
            "figures: fuzz: {} inputs, {} rejected naming a key or file, {} compile, {} generated but not compiled (over {COMPILE_AT_MOST_OBSTACLES} obstacles)",
            FUZZ_REJECTED.load(Ordering::Relaxed)
                + FUZZ_COMPILED.load(Ordering::Relaxed)
                + FUZZ_SKIPPED.load(Ordering::Relaxed),
            FUZZ_REJECTED.load(Ordering::Relaxed),
            FUZZ_COMPILED.load(Ordering::Relaxed),
            FUZZ_SKIPPED.load(Ordering::Relaxed),
        );
        if let Err(e) = result {
            panic!("{e}");
        }
    });
}

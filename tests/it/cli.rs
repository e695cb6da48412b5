//! The `simserpent` binary end to end: exit codes, run folders, tables, determinism, `init`,
//! `model`, legacy configs and user robots.

use crate::common::{data, manifest, read_csv, run_folders, simserpent, text};
use mujoco_rs::prelude::*;
use std::path::PathBuf;

const SHORT: [&str; 4] = ["--set", "general.duration_secs=0.2", "--set", "recording.every_n_steps=20"];

#[test]
fn run_writes_a_complete_run_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &[&["run"][..], &SHORT].concat());
    assert!(out.status.success(), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    for needle in ["run folder:", "distance (CoM):", "mean speed", "peak contact force"] {
        assert!(stdout.contains(needle), "summary lacks {needle}: {stdout}");
    }
    let folders = run_folders(dir.path());
    assert_eq!(folders.len(), 1);
    let run = &folders[0];
    let name = run.file_name().unwrap().to_string_lossy().to_string();
    assert!(name.starts_with("default-") && name.ends_with('Z'), "{name}");
    for file in ["config.toml", "model.xml", "manifest.json", "links.csv", "joints.csv", "sensors.csv", "contacts.csv"]
    {
        assert!(run.join(file).is_file(), "missing {file}");
    }
    let manifest = manifest(run);
    assert_eq!(manifest["status"], "complete");
    assert_eq!(manifest["mujoco_version"], "3.17.0");
    assert_eq!(manifest["seed"], 1);
    assert_eq!(manifest["steps"], 200);
    // 0.2 s at 1 ms, every 20 steps: rows at steps 0, 20, ..., 200.
    let (header, rows) = read_csv(&run.join("links.csv"));
    assert_eq!(rows.len(), 11);
    assert_eq!(header[0], "time_s");
    assert!(header.contains(&"link_09_position_x_m".to_string()));
    assert!(header.contains(&"link_00_contact_force_z_n".to_string()));
    let last_time: f64 = rows[10][0].parse().unwrap();
    assert!((last_time - 0.2).abs() < 1e-12, "{last_time}");
    let (header, _) = read_csv(&run.join("joints.csv"));
    for col in ["joint_01_angle_rad", "joint_09_position_actuator_force_nm", "joint_05_internal_torque_z_nm"] {
        assert!(header.contains(&col.to_string()), "joints.csv lacks {col}");
    }
    let (header, rows) = read_csv(&run.join("contacts.csv"));
    assert!(header.contains(&"penetration_m".to_string()));
    assert!(!rows.is_empty(), "a snake on the floor has contacts");
    assert!(rows.iter().all(|r| r[2] == "floor" || r[2].starts_with("link_") || r[2].starts_with("obstacle_")));
    // The resolved config reloads to the same run settings.
    let reloaded = simserpent::config::load_config(&run.join("config.toml"), &[]).unwrap();
    assert_eq!(reloaded.general.duration_secs, 0.2);
    // The saved model is loaded by MuJoCo's own loader, unchanged.
    let model = MjModel::from_xml(run.join("model.xml")).unwrap();
    assert_eq!(model.nu(), 4 * 9);
}

#[test]
fn recording_switches_choose_the_columns() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        &["run"][..],
        &SHORT,
        &["--set", "recording.link_orientation=false", "--set", "recording.contacts=false"],
        &["--set", "recording.imu_sensors=false", "--set", "recording.torque_actuator_forces=false"],
    ]
    .concat();
    let out = simserpent(dir.path(), &args);
    assert!(out.status.success(), "{}", text(&out));
    let run = &run_folders(dir.path())[0];
    assert!(!run.join("contacts.csv").exists());
    // imu_sensors = false drops only the IMU columns: the encoders and force/torque sensors stay.
    let (header, _) = read_csv(&run.join("sensors.csv"));
    assert!(!header.iter().any(|h| h.contains("accelerometer") || h.contains("gyro") || h.contains("velocimeter")));
    for kept in ["joint_01_encoder_true_rad", "joint_01_force_sensor_measured_x_n", "joint_01_torque_sensor_true_z_nm"]
    {
        assert!(header.iter().any(|h| h == kept), "{kept} missing in {header:?}");
    }
    let (header, _) = read_csv(&run.join("links.csv"));
    assert!(!header.iter().any(|h| h.contains("orientation")));
    let (header, _) = read_csv(&run.join("joints.csv"));
    assert!(!header.iter().any(|h| h.contains("torque_actuator")));
    assert!(header.iter().any(|h| h.contains("position_actuator")));
}

#[test]
fn same_config_and_seed_give_identical_tables() {
    let dir = tempfile::tempdir().unwrap();
    let noisy = [&["run"][..], &SHORT, &["--set", "sensors.noise_enabled=true"]].concat();
    assert!(simserpent(dir.path(), &noisy).status.success());
    assert!(simserpent(dir.path(), &noisy).status.success());
    let other_seed = [&noisy[..], &["--set", "general.seed=2"]].concat();
    assert!(simserpent(dir.path(), &other_seed).status.success());
    let folders = run_folders(dir.path());
    assert_eq!(folders.len(), 3, "each run gets its own folder");
    let read = |run: &PathBuf, table: &str| std::fs::read(run.join(table)).unwrap();
    // Folders are named by start time; find the two seed-1 runs from their configs.
    let seed_of = |run: &PathBuf| simserpent::config::load_config(&run.join("config.toml"), &[]).unwrap().general.seed;
    let (ones, twos): (Vec<&PathBuf>, Vec<&PathBuf>) = folders.iter().partition(|r| seed_of(r) == 1);
    assert_eq!((ones.len(), twos.len()), (2, 1));
    for table in ["links.csv", "joints.csv", "sensors.csv", "contacts.csv"] {
        assert_eq!(read(ones[0], table), read(ones[1], table), "{table} differs between identical runs");
    }
    assert_ne!(read(ones[0], "sensors.csv"), read(twos[0], "sensors.csv"), "another seed, other noise");
}

#[test]
fn bad_config_exits_2_names_the_key_and_creates_no_run_folder() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 4] = [
        (&["run", "--set", "snake.n_links=0"], "snake.n_links"),
        (&["run", "--set", "snake.n_link=3"], "did you mean `snake.n_links`"),
        (&["run", "--set", "snake.torque_range_nm=[3, -3]"], "snake.torque_range_nm"),
        (&["run", "--set", "general.timestep_secs=0"], "general.timestep_secs"),
    ];
    for (args, needle) in cases {
        let out = simserpent(dir.path(), args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out));
        assert!(text(&out).contains(needle), "{args:?}: {}", text(&out));
    }
    std::fs::write(dir.path().join("bad.toml"), "[snake]\nlink_radius_m = -1\n").unwrap();
    let out = simserpent(dir.path(), &["run", "bad.toml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).contains("snake.link_radius_m") && text(&out).contains("-1"), "{}", text(&out));
    let out = simserpent(dir.path(), &["run", "missing.toml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).contains("missing.toml"));
    assert!(run_folders(dir.path()).is_empty(), "no run folder for bad input");
}

/// `simserpent estimate` needs every step: a run recorded every 10th step (the default) is
/// refused with exit 2, naming the key and the fix; recorded every step, the same run is estimated.
#[test]
fn estimate_refuses_a_run_recorded_below_every_step_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let base = ["run", "--quiet", "--set", "general.duration_secs=0.05", "--set", "snake.n_links=3"];
    let out = simserpent(dir.path(), &base);
    assert!(out.status.success(), "{}", text(&out));
    let sparse = run_folders(dir.path()).remove(0);
    let out = simserpent(dir.path(), &["estimate", sparse.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    for needle in ["recording.every_n_steps = 10", "--set recording.every_n_steps=1"] {
        assert!(text(&out).contains(needle), "{needle}: {}", text(&out));
    }
    assert!(!sparse.join("estimation").exists(), "nothing written when refused");
    std::fs::remove_dir_all(&sparse).unwrap();
    let out = simserpent(dir.path(), &[&base[..], &["--set", "recording.every_n_steps=1"]].concat());
    assert!(out.status.success(), "{}", text(&out));
    let every = run_folders(dir.path()).remove(0);
    let out = simserpent(dir.path(), &["estimate", every.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(every.join("estimation/scores.md").is_file());
}

#[test]
fn init_writes_the_commented_default_and_it_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &["init"]);
    assert!(out.status.success(), "{}", text(&out));
    let written = std::fs::read_to_string(dir.path().join("config.toml")).unwrap();
    assert_eq!(written, simserpent::config::DEFAULT_CONFIG_TOML);
    assert!(written.lines().filter(|l| l.starts_with('#')).count() > 50, "fully commented");
    // A second init refuses to overwrite.
    assert_eq!(simserpent(dir.path(), &["init"]).status.code(), Some(2));
    let out = simserpent(dir.path(), &["check", "config.toml"]);
    assert!(out.status.success());
    let resolved: simserpent::config::Config = toml::from_str(&String::from_utf8_lossy(&out.stdout)).unwrap();
    assert_eq!(resolved, simserpent::config::Config::default());
}

#[test]
fn model_command_writes_mjcf_that_mujoco_loads() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &["model", "--set", "snake.n_links=7", "-o", "snake.xml"]);
    assert!(out.status.success(), "{}", text(&out));
    let model = MjModel::from_xml(dir.path().join("snake.xml")).unwrap();
    assert_eq!(model.nbody(), 1 + 7, "world and 7 links (obstacles are world geoms)");
    assert_eq!(model.njnt(), 1 + 6);
    let stdout = simserpent(dir.path(), &["model"]);
    assert!(String::from_utf8_lossy(&stdout.stdout).starts_with("<mujoco"));
}

#[test]
fn thesis_config_json_runs() {
    let dir = tempfile::tempdir().unwrap();
    let json = data("thesis_config.json");
    let out = simserpent(
        dir.path(),
        &["run", json.to_str().unwrap(), "--set", "general.duration_secs=0.2", "--set", "general.run_name=\"thesis\""],
    );
    assert!(out.status.success(), "{}", text(&out));
    let run = &run_folders(dir.path())[0];
    let config = simserpent::config::load_config(&run.join("config.toml"), &[]).unwrap();
    // The thesis file has "store_data": false: the run folder holds config, model and manifest only.
    assert!(!config.recording.enabled);
    assert!(run.join("manifest.json").is_file() && !run.join("joints.csv").exists());
    let out = simserpent(
        dir.path(),
        &["run", json.to_str().unwrap(), "--set", "general.duration_secs=0.2", "--set", "recording.enabled=true"],
    );
    assert!(out.status.success(), "{}", text(&out));
    let run = run_folders(dir.path()).into_iter().find(|r| r.join("joints.csv").exists()).unwrap();
    assert_eq!(config.snake.n_links, 2);
    assert_eq!(config.snake.link_length_m, 0.2);
    assert_eq!(config.general.timestep_secs, 0.01);
    let (_, rows) = read_csv(&run.join("joints.csv"));
    assert_eq!(rows.len(), 3, "0.2 s at 10 ms = 20 steps, recorded every 10 (steps 0, 10, 20)");
}

#[test]
fn user_robots_run_in_the_terrain_and_are_recorded() {
    // A URDF's base link gets a free joint (robot.floating_base), so it is a link of its own.
    // The URDF has no actuators (MuJoCo's URDF loader makes none), so it runs without a gait.
    let cases: [(&str, &[&str], &str, &str); 2] = [
        ("two_link_arm.xml", &["base", "arm"], "elbow", "gait.kind=\"sine_wave\""),
        ("two_link.urdf", &["base", "arm"], "elbow", "gait.kind=\"none\""),
    ];
    for (file, links, joint, gait) in cases {
        let dir = tempfile::tempdir().unwrap();
        let robot = data(file);
        let args = [
            &["run", "--robot", robot.to_str().unwrap()][..],
            &SHORT,
            &["--set", "terrain.kind=\"two_cylinders\"", "--set", gait],
        ];
        let out = simserpent(dir.path(), &args.concat());
        assert!(out.status.success(), "{file}: {}", text(&out));
        let run = &run_folders(dir.path())[0];
        assert!(run.join("robot.xml").is_file(), "the included robot is kept with the run");
        let model = MjModel::from_xml(run.join("model.xml")).unwrap();
        assert!(model.name_to_id(MjtObjBase::mjOBJ_GEOM, "obstacle_00").is_some(), "{file}: terrain added");
        assert!(model.name_to_id(MjtObjBase::mjOBJ_GEOM, "floor").is_some());
        let (header, rows) = read_csv(&run.join("links.csv"));
        for link in links {
            assert!(header.contains(&format!("{link}_position_z_m")), "{file}: {header:?}");
        }
        assert_eq!(rows.len(), 11);
        let (header, _) = read_csv(&run.join("joints.csv"));
        assert!(header.contains(&format!("{joint}_angle_rad")), "{file}: {header:?}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(dir.path(), &["run", "--robot", "nope.xml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).contains("nope.xml"));
    assert!(run_folders(dir.path()).is_empty());
}

#[test]
fn a_diverging_run_exits_1_and_leaves_readable_tables_marked_failed() {
    let dir = tempfile::tempdir().unwrap();
    // A huge servo gain with explicit Euler at 50 ms is unstable within a few steps.
    let out = simserpent(
        dir.path(),
        &[
            "run",
            "--set",
            "general.timestep_secs=0.05",
            "--set",
            "physics.contact_time_constant_secs=0.1",
            "--set",
            "control.position_kp_nm_per_rad=100000",
            "--set",
            "general.integrator=\"Euler\"",
            "--set",
            "snake.torque_range_nm=[-1e6, 1e6]",
            "--set",
            "recording.every_n_steps=1",
        ],
    );
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("diverged at t ="), "{}", text(&out));
    let run = &run_folders(dir.path())[0];
    let manifest = manifest(run);
    assert_eq!(manifest["status"], "failed");
    assert!(manifest["error"].as_str().unwrap().contains("diverged"));
    let (_, rows) = read_csv(&run.join("links.csv"));
    assert!(!rows.is_empty(), "the rows recorded before the failure are kept");
}
